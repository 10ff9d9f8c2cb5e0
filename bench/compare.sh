#!/usr/bin/env bash
# One command: gatcore vs the current PyTorch + PyTorch Geometric on the same workloads.
#   bash bench/compare.sh [compare_pyg.py options, e.g. --only densegats_train --json out.json]
# The reference is what someone starting today installs from the package
# index: torch (the default PyPI wheel: MKL + oneDNN on x86-64 CPUs) and
# torch_geometric, in a virtual environment (GATCORE_TORCH_VENV, default
# build/torch-venv; created on first use). Versions are pinned below so runs
# compare like with like; bump them deliberately. Each workload runs eager and
# under torch.compile; the faster is the reference. Builds gatbench (Release);
# 2 threads on both sides. Not part of CI (minutes, and it downloads torch).
# The former reference (Debian's torch 1.13 on OpenBLAS) is kept in
# bench/RESULTS.md as history only.
set -euo pipefail
cd "$(dirname "$0")/.."
TORCH_VERSION=${TORCH_VERSION:-2.15.0}
PYG_VERSION=${PYG_VERSION:-2.8.1}
VENV=${GATCORE_TORCH_VENV:-build/torch-venv}
PY=$VENV/bin/python

if [ ! -x "$PY" ]; then
  python3 -m venv "$VENV" || {
    echo "compare.sh: python3 -m venv failed; on Debian: apt-get install python3-venv" >&2
    exit 1
  }
fi
have=$("$PY" -c 'import torch, torch_geometric as g; print(torch.__version__.split("+")[0], g.__version__)' 2>/dev/null || true)
if [ "$have" != "$TORCH_VERSION $PYG_VERSION" ]; then
  "$PY" -m pip install --upgrade pip >/dev/null
  "$PY" -m pip install "torch==$TORCH_VERSION" "torch_geometric==$PYG_VERSION"
fi

if [ ! -x build/bench/gatbench ]; then
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build build --target gatbench

# OMP_WAIT_POLICY is left to the caller: unset, both sides run the OpenMP
# runtime's default (spin a while, then sleep), what users get. `passive`
# (threads sleep at once) suited the oversubscribed machine of earlier runs
# and costs gatcore's short parallel regions 15-40 % on a quiet one
# (GAT layer fwd+bwd 2.5 -> 4.0 ms, DenseGATs step 342 -> 406 ms).
export OMP_NUM_THREADS=2 MKL_NUM_THREADS=2
lscpu | grep -E '^Model name' || true
"$PY" -c 'import sys, torch, torch_geometric as g
print("python", sys.version.split()[0], "| torch", torch.__version__, "| torch_geometric", g.__version__)
print(torch.__config__.show())
print(torch.__config__.parallel_info())'
echo "uptime before: $(uptime)"
"$PY" bench/compare_pyg.py --gatbench build/bench/gatbench --threads 2 "$@"
echo "uptime after: $(uptime)"
