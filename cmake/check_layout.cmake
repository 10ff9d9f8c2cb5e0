# Dependency direction of the library's layers, checked on the #include lines
# of include/ and src/:
#   cmake -DGATCORE_ROOT=<dir with include/ and src/> [-DGATCORE_TARGET_LAYER=<layer>] -P cmake/check_layout.cmake
# Fails (listing every offending line) when a file includes a layer it may not
# depend on, a private header of a backend from outside that backend, when a
# header sits directly in gatcore/character/ (outside a layer), or when a
# character folder is not in the table below. With GATCORE_TARGET_LAYER (core,
# nn, train, runtime, character) only that library's files are checked: each
# layer's build runs it first (CMakeLists.txt gatcore_layer_check), so a
# wrong-way include fails the build; without it, every file (ctest
# layout_dependency_direction). docs/architecture.md draws the layers.
#
# Libraries, bottom to top, and the folders of each:
#   core       include/gatcore/*.hpp (but optim.hpp, runtime.hpp, gatcore.h), src/*.cpp,
#              src/ops/, src/backends/ (cpu/: private but for backend_cpu.hpp and
#              inference.hpp, the backend's entries; vulkan/: private)
#   nn         include/gatcore/{nn,models}/ (but models/train.hpp, distill.hpp), src/nn/, src/models/
#   train      include/gatcore/models/{train,distill}.hpp, optim.hpp, dist/, train/, src/train/
#   runtime    character layers rig, deform, features, inference, and runtime
#              (include/gatcore/runtime.hpp, gatcore.h, src/runtime/)
#   character  character layers io, data, eval, viz
# Layers of include/gatcore/character/<layer>/ and src/character/<layer>/, bottom
# to top:
#   rig        mesh, skeleton, pose, transforms, motion retargeting, welding, joint limits, super skeleton
#   deform     the reference deformers: LBS, DQS, Delta Mush, detail distortion
#   io         file formats of characters and motions: glTF, assimp, BVH, baked caches
#   features   node features, normalisation, the prepared character and its per-frame features
#   data       training data: datasets (and their files), samples, procedural characters
#   eval       metrics, skin-weight evaluation, the motion evaluation harness (its error maps: viz)
#   viz        software rasteriser, plots, loss curves
#   inference  a trained model applied to a character: per-frame correctives, predicted weights, and
#              the checkpoint's model description; below data and eval, which train and evaluate
#              models (they write and read that description)
#   runtime    the engine-facing API above them: models, rig, deform, features,
#              inference; never datasets, importers, training, pictures
cmake_minimum_required(VERSION 3.22)
set(_allowed_core core)
set(_allowed_nn core nn)
set(_allowed_train core nn train)
set(_allowed_rig core nn rig)
set(_allowed_deform core nn rig deform)
set(_allowed_features core nn rig deform features)
set(_allowed_inference core nn rig deform features inference)
set(_allowed_runtime core nn rig deform features inference runtime)
set(_allowed_io core nn train rig deform io)
set(_allowed_data core nn train rig deform io features inference data)
set(_allowed_eval core nn train rig deform features inference data viz eval)
set(_allowed_viz core nn train rig viz)
foreach(_l rig deform features inference runtime)
  set(_library_of_${_l} runtime)
endforeach()
foreach(_l io data eval viz)
  set(_library_of_${_l} character)
endforeach()
foreach(_l core nn train)
  set(_library_of_${_l} ${_l})
endforeach()

if(NOT GATCORE_ROOT)
  message(FATAL_ERROR "check_layout: pass -DGATCORE_ROOT=<source dir>")
endif()
if(GATCORE_TARGET_LAYER AND NOT GATCORE_TARGET_LAYER MATCHES "^(core|nn|train|runtime|character)$")
  message(FATAL_ERROR "check_layout: unknown GATCORE_TARGET_LAYER '${GATCORE_TARGET_LAYER}'")
endif()

# The layer a path (relative to GATCORE_ROOT, or an include string) belongs to:
# a layer name, "cpu_private" / "vulkan_private" (a backend's own files),
# "loose" (directly in character/) or "" (not checked).
function(_layer_of path out)
  # (One MATCHES per if(): CMake evaluates both sides of an OR, and a failed
  # match clears CMAKE_MATCH_n.)
  set(_l "")
  if(path MATCHES "^(include/)?gatcore/character/([^/]+)/")
    set(_l "${CMAKE_MATCH_2}")
  elseif(path MATCHES "^src/character/([^/]+)/")
    set(_l "${CMAKE_MATCH_1}")
  elseif(path MATCHES "^(include/)?gatcore/(runtime\\.hpp|gatcore\\.h)$")
    set(_l runtime)
  elseif(path MATCHES "^src/runtime/")
    set(_l runtime)
  elseif(path MATCHES "^(include/)?gatcore/character/")
    set(_l loose)
  elseif(path MATCHES "^src/character/")
    set(_l loose)
  elseif(path MATCHES "^(include/)?gatcore/(models/train\\.hpp|models/distill\\.hpp|optim\\.hpp|dist/|train/)")
    set(_l train)
  elseif(path MATCHES "^src/train/")
    set(_l train)
  elseif(path MATCHES "^(include/)?gatcore/(models|nn)/")
    set(_l nn)
  elseif(path MATCHES "^src/(models|nn)/")
    set(_l nn)
  elseif(path MATCHES "^src/backends/cpu/(backend_cpu|inference)\\.hpp$")
    set(_l core)
  elseif(path MATCHES "^src/backends/cpu/")
    set(_l cpu_private)
  elseif(path MATCHES "^src/backends/vulkan/")
    set(_l vulkan_private)
  elseif(path MATCHES "^(include/)?gatcore/")
    set(_l core)
  elseif(path MATCHES "^src/")
    set(_l core)
  endif()
  set(${out} "${_l}" PARENT_SCOPE)
endfunction()

file(GLOB_RECURSE _files RELATIVE "${GATCORE_ROOT}"
  "${GATCORE_ROOT}/include/*.hpp" "${GATCORE_ROOT}/include/*.h"
  "${GATCORE_ROOT}/src/*.cpp" "${GATCORE_ROOT}/src/*.hpp" "${GATCORE_ROOT}/src/*.h" "${GATCORE_ROOT}/src/*.inc")
set(_errors "")
set(_checked 0)
foreach(f IN LISTS _files)
  _layer_of("${f}" from)
  if(from STREQUAL "")
    continue()
  endif()
  # A backend's own files may include each other (the CPU entry headers too).
  set(_private_dir "")
  if(f MATCHES "^src/backends/cpu/")
    set(_private_dir cpu_private)
  elseif(f MATCHES "^src/backends/vulkan/")
    set(_private_dir vulkan_private)
  endif()
  if(from MATCHES "_private$")
    set(from core)
  endif()
  if(from STREQUAL "loose")
    string(APPEND _errors "  ${f}: outside any layer folder of character/\n")
    continue()
  endif()
  if(NOT DEFINED _allowed_${from})
    string(APPEND _errors "  ${f}: unknown layer '${from}' (add it to cmake/check_layout.cmake)\n")
    continue()
  endif()
  if(GATCORE_TARGET_LAYER AND NOT _library_of_${from} STREQUAL GATCORE_TARGET_LAYER)
    continue()
  endif()
  file(STRINGS "${GATCORE_ROOT}/${f}" _incs REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<][^\">]+[\">]")
  foreach(line IN LISTS _incs)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*[\"<]([^\">]+)[\">].*$" "\\1" inc "${line}")
    _layer_of("${inc}" to)
    if(to STREQUAL "")
      continue()
    endif()
    math(EXPR _checked "${_checked} + 1")
    if(to STREQUAL "loose")
      string(APPEND _errors "  ${f}: #include \"${inc}\" is outside any layer folder\n")
    elseif(to MATCHES "_private$")
      if(NOT to STREQUAL _private_dir)
        string(APPEND _errors "  ${f} (${from}): #include \"${inc}\" is private to its backend "
                              "(the CPU backend's entries: src/backends/cpu/backend_cpu.hpp, inference.hpp)\n")
      endif()
    elseif(NOT to IN_LIST _allowed_${from})
      string(APPEND _errors "  ${f} (${from}): #include \"${inc}\" (${to}) runs against the layer order\n")
    endif()
  endforeach()
endforeach()

if(_errors)
  message(FATAL_ERROR "check_layout: dependency direction violated:\n${_errors}")
endif()
if(_checked EQUAL 0)
  message(FATAL_ERROR "check_layout: no gatcore #include found under ${GATCORE_ROOT}: wrong root?")
endif()
if(GATCORE_TARGET_LAYER)
  message(STATUS "check_layout: ${_checked} includes of the ${GATCORE_TARGET_LAYER} layer follow the layer order")
else()
  message(STATUS "check_layout: ${_checked} includes follow the layer order")
endif()
