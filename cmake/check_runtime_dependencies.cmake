# What an engine that links gatcore::runtime pulls in: run by the ctest
# layout_runtime_dependencies on the built shared runtime
# (gatcore_runtime_shared, linked with --no-undefined) and on the link
# interfaces CMake generated for the runtime and the layers under it:
#   cmake -DRUNTIME_SO=<libgatcore_runtime_shared.so> -DLINK_INFO=<file> -P cmake/check_runtime_dependencies.cmake
# Fails, naming what it found, when `ldd` lists an importer's, MPI's, zlib's or
# oneTBB's library (the runtime's loops are OpenMP; oneTBB is the character
# layer's data pipeline), when `nm` finds a symbol of an importer, of MPI, of
# oneTBB or of the train layer (Trainer, Adam, communicators, distillation,
# training state), or when a link interface names them or the train /
# character layers.
cmake_minimum_required(VERSION 3.22)
foreach(var RUNTIME_SO LINK_INFO)
  if(NOT DEFINED ${var} OR NOT EXISTS "${${var}}")
    message(FATAL_ERROR "check_runtime_dependencies: -D${var}=<existing file> is required (got '${${var}}')")
  endif()
endforeach()
find_program(LDD ldd REQUIRED)
find_program(NM nm REQUIRED)

set(_errors "")
execute_process(COMMAND ${LDD} "${RUNTIME_SO}" OUTPUT_VARIABLE _ldd RESULT_VARIABLE _rv)
if(NOT _rv EQUAL 0)
  message(FATAL_ERROR "check_runtime_dependencies: ldd ${RUNTIME_SO} failed (${_rv})")
endif()
string(REGEX MATCHALL "[^\n]*(assimp|draco|meshoptimizer|tinygltf|libmpi|open-pal|open-rte|libz\\.so|libtbb|gatcore_train|gatcore_character)[^\n]*" _bad "${_ldd}")
foreach(l IN LISTS _bad)
  string(APPEND _errors "  ldd: ${l}\n")
endforeach()

# (grep filters nm's listing: a CMake regex over the whole listing takes seconds.)
find_program(GREP grep REQUIRED)
execute_process(COMMAND ${NM} -C "${RUNTIME_SO}" COMMAND ${GREP} -c "gatcore_deformer_load"
                OUTPUT_VARIABLE _own RESULT_VARIABLE _rv OUTPUT_STRIP_TRAILING_WHITESPACE)
# A symbol the runtime itself must define (the C API): the listing is real.
if(NOT _rv EQUAL 0 OR NOT _own GREATER 0)
  message(FATAL_ERROR "check_runtime_dependencies: nm shows no gatcore_deformer_load in ${RUNTIME_SO}: wrong library?")
endif()
execute_process(COMMAND ${NM} -C "${RUNTIME_SO}"
                COMMAND ${GREP} -E "tinygltf::|draco::|meshopt_|Assimp::|aiImport|MPI_|ompi_|tbb::|gatcore::models::Trainer|gatcore::Adam|gatcore::dist::|gatcore::models::distill_targets|gatcore::models::restore_training_state"
                OUTPUT_VARIABLE _nm)
if(NOT _nm STREQUAL "")
  string(REPLACE "\n" ";" _bad "${_nm}")
  list(LENGTH _bad _n)
  if(_n GREATER 10)
    list(SUBLIST _bad 0 10 _bad)
  endif()
  foreach(l IN LISTS _bad)
    string(APPEND _errors "  nm: ${l}\n")
  endforeach()
endif()

file(STRINGS "${LINK_INFO}" _links)
foreach(l IN LISTS _links)
  if(l MATCHES "assimp|draco|meshoptimizer|tinygltf|MPI|ZLIB|TBB|tbb|gatcore_train|gatcore_character|gatcore::train|gatcore::character")
    string(APPEND _errors "  link interface: ${l}\n")
  endif()
endforeach()

if(_errors)
  message(FATAL_ERROR "check_runtime_dependencies: the runtime depends on what it must not:\n${_errors}")
endif()
message(STATUS "check_runtime_dependencies: ${RUNTIME_SO} needs no importer, MPI, oneTBB or trainer:\n${_ldd}")
