# Installs the gatcore build into a scratch prefix, then configures, builds and
# runs tests/downstream/project against it with find_package(gatcore).
#
#   cmake -DSOURCE_DIR=<gatcore source> -DBINARY_DIR=<gatcore build> \
#         -DWORK_DIR=<scratch dir> [-DGENERATOR=<cmake generator>] \
#         -P run_downstream_test.cmake
cmake_minimum_required(VERSION 3.22)

foreach(var SOURCE_DIR BINARY_DIR WORK_DIR)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "downstream test: -D${var}=... is required")
  endif()
endforeach()
if(NOT EXISTS "${BINARY_DIR}/CMakeCache.txt")
  message(FATAL_ERROR "downstream test: ${BINARY_DIR} is not a configured gatcore build directory")
endif()

set(prefix "${WORK_DIR}/prefix")
set(project_src "${SOURCE_DIR}/tests/downstream/project")
set(project_bin "${WORK_DIR}/build")

# Settings of the main build that the consumer should share.
file(STRINGS "${BINARY_DIR}/CMakeCache.txt" _cxx REGEX "^CMAKE_CXX_COMPILER:[A-Z]+=")
string(REGEX REPLACE "^[^=]*=" "" cxx_compiler "${_cxx}")
file(STRINGS "${BINARY_DIR}/CMakeCache.txt" _bt REGEX "^CMAKE_BUILD_TYPE:[A-Z]+=")
string(REGEX REPLACE "^[^=]*=" "" build_type "${_bt}")
if(build_type STREQUAL "")
  set(build_type Release)
endif()

if(NOT DEFINED GENERATOR OR GENERATOR STREQUAL "")
  find_program(_ninja NAMES ninja ninja-build)
  if(_ninja)
    set(GENERATOR Ninja)
  else()
    set(GENERATOR "Unix Makefiles")
  endif()
endif()

# Runs one step; stops the test with the step's name and output on failure.
function(run_step name)
  execute_process(COMMAND ${ARGN}
    RESULT_VARIABLE rv OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rv EQUAL 0)
    message(FATAL_ERROR "downstream test: ${name} failed (${rv})\n"
      "command: ${ARGN}\n--- stdout ---\n${out}\n--- stderr ---\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

# Start from nothing so a stale prefix or build cannot make the test pass.
file(REMOVE_RECURSE "${prefix}" "${project_bin}")

# 1. Install.
message(STATUS "installing ${BINARY_DIR} into ${prefix}")
run_step("cmake --install" ${CMAKE_COMMAND} --install "${BINARY_DIR}" --prefix "${prefix}" --config "${build_type}")

# 2. The installed package must not point back at the source or build tree.
file(GLOB_RECURSE config_files "${prefix}/*.cmake")
if(NOT config_files)
  message(FATAL_ERROR "downstream test: the install put no CMake package files under ${prefix}")
endif()
foreach(f IN LISTS config_files)
  file(READ "${f}" text)
  foreach(tree "${SOURCE_DIR}" "${BINARY_DIR}")
    string(FIND "${text}" "${tree}" pos)
    if(NOT pos EQUAL -1)
      message(FATAL_ERROR "downstream test: installed ${f} refers to the build-time path ${tree}")
    endif()
  endforeach()
endforeach()

# 3. Configure and build the consumer against the prefix only.
set(configure_args -S "${project_src}" -B "${project_bin}" -G "${GENERATOR}"
  "-DCMAKE_BUILD_TYPE=${build_type}"
  "-DCMAKE_PREFIX_PATH=${prefix}"
  "-DGATCORE_EXPECTED_PREFIX=${prefix}"
  -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
  -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
if(cxx_compiler)
  list(APPEND configure_args "-DCMAKE_CXX_COMPILER=${cxx_compiler}")
endif()
message(STATUS "configuring the consumer (${GENERATOR}, ${build_type})")
run_step("configure of the downstream project" ${CMAKE_COMMAND} ${configure_args})
message(STATUS "building the consumer")
run_step("build of the downstream project" ${CMAKE_COMMAND} --build "${project_bin}" --config "${build_type}")

# 4. Run it and check what it prints.
# Runs the consumer's program `name`; its output goes to step_output.
function(run_program name)
  find_program(_exe_${name} NAMES ${name} PATHS "${project_bin}" "${project_bin}/${build_type}" NO_DEFAULT_PATH)
  if(NOT _exe_${name})
    message(FATAL_ERROR "downstream test: the build produced no ${name} executable in ${project_bin}")
  endif()
  run_step("running ${_exe_${name}}" "${_exe_${name}}")
  message(STATUS "${name} printed:\n${step_output}")
  set(step_output "${step_output}" PARENT_SCOPE)
endfunction()
run_program(app)
set(expected
  "nodes=9 edges=41 max_degree=7 symmetric=1 self_loops=1 row4=0,1,3,4,5,7,8"
  "tensor=[2, 3] slice=[2, 2] slice_sum=16"
  "error=InvalidArgument")
foreach(line IN LISTS expected)
  string(FIND "${step_output}" "${line}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "downstream test: app output lacks the line\n  ${line}\nit printed:\n${step_output}")
  endif()
endforeach()

# 5. The C API engine, linked against gatcore::runtime alone.
run_program(engine)
if(NOT step_output MATCHES "engine: version=[0-9.]+ load=GATCORE_ERROR_IO deformer=null names_file=1")
  message(FATAL_ERROR "downstream test: engine output is not the expected line; it printed:\n${step_output}")
endif()
message(STATUS "downstream test passed")
