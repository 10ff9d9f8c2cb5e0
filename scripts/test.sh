#!/usr/bin/env bash
# Installs missing build dependencies, configures (Release, Ninja) into build/,
# builds everything and runs the whole test suite. This is what CI runs.
# Usage: bash scripts/test.sh   (from anywhere)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="build"

bash scripts/install_deps.sh

# A build/ made by another generator cannot be reused by Ninja: start over.
if [[ -f "$build/CMakeCache.txt" ]] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$build/CMakeCache.txt"; then
  echo "test.sh: $build/ was configured with another generator; removing it" >&2
  rm -rf "$build"
fi

# Python's safetensors for the ctest checkpoint_python_resave (a re-saved
# checkpoint must still load), in a venv inside the build folder; without
# network the test says SKIPPED instead.
if ! "$build/pyvenv/bin/python3" -c 'import safetensors.numpy' 2>/dev/null; then
  mkdir -p "$build"
  { python3 -m venv "$build/pyvenv" && "$build/pyvenv/bin/pip" install -q safetensors numpy; } ||
    echo "test.sh: could not install Python's safetensors; checkpoint_python_resave will be skipped" >&2
fi

cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j2
ctest --test-dir "$build" --output-on-failure -j2
