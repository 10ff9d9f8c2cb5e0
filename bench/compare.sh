#!/usr/bin/env bash
# One command: gatcore vs PyTorch + PyTorch Geometric on the same workloads.
#   bash bench/compare.sh [compare_pyg.py options, e.g. --only densegats_train --json out.json]
# Installs the reference stack if missing (Debian 12, as root or with sudo):
# Debian's python3-torch 1.13 on OpenBLAS (libopenblas0-pthread becomes the
# system libblas.so.3, which Debian's torch uses) and PyG 2.6.1 via pip into
# Debian's /usr/bin/python3; builds gatbench (Release); runs both sides with
# 2 threads. Not part of CI (minutes, and it installs packages).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=/usr/bin/python3
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO=sudo

need=()
$PY -c 'import torch' 2>/dev/null || need+=(python3-torch)
dpkg -s libopenblas0-pthread >/dev/null 2>&1 || need+=(libopenblas0-pthread)
$PY -m pip --version >/dev/null 2>&1 || need+=(python3-pip)
if [ ${#need[@]} -gt 0 ]; then
  $SUDO apt-get update
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${need[@]}"
fi
if [ "$($PY -c 'import torch_geometric; print(torch_geometric.__version__)' 2>/dev/null)" != "2.6.1" ]; then
  $SUDO $PY -m pip install --break-system-packages torch_geometric==2.6.1
fi
blas=$(readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3 || true)
case "$blas" in
  *openblas*) ;;
  *) echo "compare.sh: libblas.so.3 is $blas, not OpenBLAS; run: update-alternatives --config libblas.so.3-x86_64-linux-gnu" >&2 ;;
esac

if [ ! -x build/bench/gatbench ]; then
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build build --target gatbench

# OpenBLAS 0.3.21 does not recognise this CPU model and would fall back to its
# generic kernels; SkylakeX is its AVX-512 path.
export OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-SkylakeX}
export OMP_NUM_THREADS=2 OPENBLAS_NUM_THREADS=2 OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
lscpu | grep -E '^Model name' || true
echo "uptime before: $(uptime)"
$PY bench/compare_pyg.py --gatbench build/bench/gatbench --threads 2 "$@"
echo "uptime after: $(uptime)"
