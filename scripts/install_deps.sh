#!/usr/bin/env bash
# Installs the Debian 12 packages gatcore needs to build and test, if any are
# missing (a no-op, without touching apt, when all are installed). Runs apt
# through sudo when not root. Used by scripts/test.sh and .ci/run.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libomp-dev libtbb-dev catch2 libbenchmark-dev
  libtinygltf-dev nlohmann-json3-dev libassimp-dev
  # Vulkan backend: headers/loader, the GLSL compiler, and Mesa lavapipe (a
  # CPU Vulkan device) so the Vulkan tests run without a GPU.
  glslang-tools libvulkan-dev mesa-vulkan-drivers vulkan-tools
  # Data-parallel training (src/dist/): Open MPI's library and mpirun, which
  # the tests/dist/ tests launch at 2 and 4 ranks.
  libopenmpi-dev openmpi-bin
)

missing=()
for p in "${packages[@]}"; do
  status="$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)"
  [[ "$status" == "installed" ]] || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "install_deps: all build dependencies are installed"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
sudo=()
if [[ "$(id -u)" -ne 0 ]]; then
  if ! command -v sudo >/dev/null; then
    echo "install_deps: not root and no sudo; install these as root: apt-get install ${missing[*]}" >&2
    exit 1
  fi
  sudo=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -q
"${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
