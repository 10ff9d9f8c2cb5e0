#!/usr/bin/env bash
# The README's first command: installs missing Debian packages, builds the
# library and the `gat` tool (Release, Ninja, into build/), and runs the main
# job on the embedded default data: `gat demo`.
# Usage: bash scripts/demo.sh [gat demo options, e.g. --epochs 1200 --seed 3]
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="build"

bash scripts/install_deps.sh
if [[ -f "$build/CMakeCache.txt" ]] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$build/CMakeCache.txt"; then
  echo "demo.sh: $build/ was configured with another generator; removing it" >&2
  rm -rf "$build"
fi
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j2 --target gat
"$build/examples/gat" demo "$@"
