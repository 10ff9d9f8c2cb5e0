# Sanitizer and fuzzer builds (included by the top-level CMakeLists.txt before
# any target is defined, so every target -- library, tests, examples, fuzz
# harnesses -- is instrumented the same way).
#
#   -DGATCORE_SANITIZE=address,undefined   -fsanitize=<list> on compile and link;
#                                          UB is fatal (-fno-sanitize-recover)
#   -DGATCORE_FUZZ=ON                      tests/fuzz/: libFuzzer harnesses
#                                          (clang); with GCC the same harnesses
#                                          get a replay-only main
# scripts/sanitize.sh configures both in one clang build (build-asan/), runs
# the test suite under it and each fuzzer for a bounded time.
set(GATCORE_SANITIZE "" CACHE STRING "Comma-separated -fsanitize= list (e.g. address,undefined); empty: none")
option(GATCORE_FUZZ "Build tests/fuzz as libFuzzer fuzzers (needs clang; otherwise they are replay-only)" OFF)

if(GATCORE_SANITIZE)
  add_compile_options(-fsanitize=${GATCORE_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${GATCORE_SANITIZE})
  if(GATCORE_SANITIZE MATCHES "undefined")
    # Float -> integer casts of out-of-range values (file-provided numbers):
    # part of "undefined" in clang, separate in GCC.
    add_compile_options(-fsanitize=float-cast-overflow)
    add_link_options(-fsanitize=float-cast-overflow)
  endif()
endif()

set(GATCORE_LIBFUZZER OFF)
if(GATCORE_FUZZ AND CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  set(GATCORE_LIBFUZZER ON)
  # Coverage instrumentation for everything (the loaders live in the library);
  # the harness executables link libFuzzer's main (tests/fuzz/CMakeLists.txt).
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
