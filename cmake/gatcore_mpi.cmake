# Data-parallel training over MPI (src/train/dist/mpi_communicator.cpp), included by
# the top-level CMakeLists.txt after the gatcore_train target exists.
#
# GATCORE_MPI=AUTO builds it when CMake finds MPI (Debian: libopenmpi-dev),
# ON requires it, OFF skips it. Without it the library is the same except
# that dist::world() is always a group of one.
set(GATCORE_HAVE_MPI OFF)
set(GATCORE_CONFIG_FIND_MPI OFF)
string(TOUPPER "${GATCORE_MPI}" _gatcore_mpi_mode)
if(NOT _gatcore_mpi_mode STREQUAL "OFF")
  # The C API through the C++ compiler (the project enables only CXX); not
  # the deprecated MPI C++ bindings.
  set(MPI_CXX_SKIP_MPICXX ON)
  find_package(MPI COMPONENTS CXX QUIET)
  if(MPI_CXX_FOUND)
    set(GATCORE_HAVE_MPI ON)
  elseif(_gatcore_mpi_mode STREQUAL "ON")
    message(FATAL_ERROR "GATCORE_MPI=ON but MPI was not found; install libopenmpi-dev")
  else()
    message(STATUS "gatcore: MPI not found; data-parallel training disabled (install libopenmpi-dev)")
  endif()
endif()
if(GATCORE_HAVE_MPI)
  message(STATUS "gatcore: MPI enabled (${MPIEXEC_EXECUTABLE})")
  target_sources(gatcore_train PRIVATE ${PROJECT_SOURCE_DIR}/src/train/dist/mpi_communicator.cpp)
  target_link_libraries(gatcore_train PRIVATE MPI::MPI_CXX)
  target_compile_definitions(gatcore_train PRIVATE GATCORE_HAS_MPI)
  if(NOT BUILD_SHARED_LIBS)
    set(GATCORE_CONFIG_FIND_MPI ON)  # a static gatcore's consumers link MPI too
  endif()
endif()
