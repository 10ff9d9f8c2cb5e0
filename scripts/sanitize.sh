#!/usr/bin/env bash
# The sanitizer and fuzzing job of CI: one clang build (build-asan/) with
# AddressSanitizer + UndefinedBehaviorSanitizer (+ LeakSanitizer, with the
# third-party suppressions of tests/sanitizer/lsan.supp) and libFuzzer
# coverage, serving both
#   1. the test suite under the sanitizers (the Vulkan variant re-runs that
#      only change lavapipe's vector width / staging / binding size are
#      left to the Release suite: same code paths, 4x the lavapipe time
#      under ASan; the benchmarks are not built), and
#   2. every fuzzer for GATCORE_FUZZ_SECONDS (default 30) each, from the
#      seed corpus plus the shared reproducers and tests/fuzz/found.
# Usage: bash scripts/sanitize.sh [--build-only|--fuzz-only]   (from anywhere)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${GATCORE_ASAN_BUILD:-build-asan}"
seconds="${GATCORE_FUZZ_SECONDS:-30}"
mode="${1:-all}"

export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=0"
export LSAN_OPTIONS="suppressions=$root/tests/sanitizer/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

if [[ "$mode" != "--fuzz-only" ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DGATCORE_SANITIZE=address,undefined -DGATCORE_FUZZ=ON -DGATCORE_BUILD_BENCH=OFF
  cmake --build "$build" -j2
  [[ "$mode" == "--build-only" ]] && exit 0
  # Variants of the Vulkan tests (see above) and the install test (it
  # rebuilds a project against the package; nothing sanitizer-specific).
  # Also left to the Release suite: the end-to-end runs that train models for
  # many steps (the experiments, gat demo / train on datasets, the MPI runs,
  # Blender's import, the nearest-joint and progress-line CLI runs): the same library code as the unit tests, at training
  # sizes, which under ASan + libFuzzer coverage take 10-30 times as long and
  # would push CI past its time. Every loader, writer and kernel still runs
  # here through the unit tests, the CLI bad-input tests and the fuzz replays.
  # The list is tests/sanitizer/release_only.regex. ctest does not add an
  # excluded set-up back, so a test that needs one (gat_heat_blend,
  # gat_world_columns and gat_calibrate need gat_skinweights_any's model) goes
  # with it, and scripts/check_ctest_fixtures.py refuses a list that forgets
  # one. blend_weights, the runtime's mix, the world columns' normaliser and
  # the calibration grid still run here in the unit tests.
  exclude="$root/tests/sanitizer/release_only.regex"
  python3 scripts/check_ctest_fixtures.py "$build" "$exclude"
  ctest --test-dir "$build" --output-on-failure -j2 -E "$(cat "$exclude")"
fi

# Each fuzzer for a bounded time on a scratch copy of its corpus (new inputs
# land there, not in the build's seed folder). -rss_limit_mb: a loader that
# asks for gigabytes for a small file is a defect, reported as such.
work="$(cd "$build" && pwd)/fuzz_run"  # absolute: each fuzzer runs inside it
rm -rf "$work"
"$build/tests/fuzz/make_corpus" "$build/tests/fuzz/corpus" >/dev/null
total=0
for f in checkpoint bvh asf pc2 gltf dataset; do
  mkdir -p "$work/$f"
  cp "$build/tests/fuzz/corpus/$f"/* "$work/$f/"
  log="$work/$f.log"
  if ! (cd "$work" && "../tests/fuzz/fuzz_$f" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20 \
          -print_final_stats=1 "$f" "$root/tests/fuzz/repro" "$root/tests/fuzz/found" >"$log" 2>&1); then
    tail -n 60 "$log"
    echo "sanitize: fuzz_$f found a defect (reproducer: $work/crash-* / leak-* / timeout-* / oom-*)" >&2
    exit 1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  total=$((total + runs))
  echo "sanitize: fuzz_$f: $runs executions in ${seconds} s, no defect"
done
echo "sanitize: fuzzing: $total executions in all, no defect"
