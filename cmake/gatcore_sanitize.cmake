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
endif()

# Coverage instrumentation where the fuzzers need it: the library (the loaders
# live there) and the harnesses. Not the tests and tools that drive the
# library: coverage there guides no fuzzer and only costs compile time.
function(gatcore_fuzz_coverage target)
  if(GATCORE_LIBFUZZER)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# Optimisation of the code that drives the library (test executables, the
# Catch2 main, the gat CLI and examples): what they run is the library's
# code, compiled as the build type says; their own code is checks, option
# parsing and small reference loops. Under the sanitizers they build at -O0
# (a Catch2 test file takes 5 s instead of 16 s with clang's ASan at -O1,
# and the two builds of CI are compile-bound on 2 cores); in optimised
# builds the tests build at -O1 (7 s instead of 11 s at -O3). The CLI and
# examples keep the build type's flags outside the sanitizer build: users
# run them.
function(gatcore_driver_flags target kind)
  if(GATCORE_SANITIZE)
    target_compile_options(${target} PRIVATE -O0)
  elseif(kind STREQUAL "test")
    target_compile_options(${target} PRIVATE $<$<CONFIG:Release,RelWithDebInfo,MinSizeRel>:-O1>)
  endif()
endfunction()
