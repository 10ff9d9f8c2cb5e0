# Dependency direction of the character pipeline (and of the core under it),
# checked on the #include lines of include/ and src/:
#   cmake -DGATCORE_ROOT=<dir with include/ and src/> -P cmake/check_layout.cmake
# Fails (listing every offending line) when a file includes a layer it may not
# depend on, when a header sits directly in gatcore/character/ (outside a
# layer), or when a layer folder is not in the table below.
#
# Layers of include/gatcore/character/<layer>/ and src/character/<layer>/, bottom
# to top (README "Layout"):
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
#   runtime    the engine-facing API above them (include/gatcore/runtime.hpp, gatcore.h, src/runtime/):
#              models, rig, deform, features, inference; never datasets, importers, training, pictures
# The core (include/gatcore/*.hpp, models/, nn/, src/*.cpp, ops/, vulkan/) never
# includes the character pipeline.
cmake_minimum_required(VERSION 3.22)
set(_allowed_rig rig)
set(_allowed_deform rig deform)
set(_allowed_io rig deform io)
set(_allowed_features rig deform features)
set(_allowed_data rig deform io features inference data)
set(_allowed_eval rig deform features inference data viz eval)
set(_allowed_viz rig viz)
set(_allowed_inference rig deform features inference)
set(_allowed_runtime rig deform features inference runtime)
set(_allowed_core "")
set(_layers rig deform io features data eval viz inference runtime)

if(NOT GATCORE_ROOT)
  message(FATAL_ERROR "check_layout: pass -DGATCORE_ROOT=<source dir>")
endif()

# The layer a path (relative to GATCORE_ROOT, or an include string) belongs to:
# a layer name, "core", "loose" (directly in character/) or "" (not checked).
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
  elseif(path MATCHES "^include/gatcore/")
    set(_l core)
  elseif(path MATCHES "^src/")
    set(_l core)
  endif()
  set(${out} "${_l}" PARENT_SCOPE)
endfunction()

file(GLOB_RECURSE _files RELATIVE "${GATCORE_ROOT}"
  "${GATCORE_ROOT}/include/*.hpp" "${GATCORE_ROOT}/include/*.h"
  "${GATCORE_ROOT}/src/*.cpp" "${GATCORE_ROOT}/src/*.hpp" "${GATCORE_ROOT}/src/*.h")
set(_errors "")
set(_checked 0)
foreach(f IN LISTS _files)
  _layer_of("${f}" from)
  if(from STREQUAL "")
    continue()
  endif()
  if(from STREQUAL "loose")
    string(APPEND _errors "  ${f}: outside any layer folder of character/\n")
    continue()
  endif()
  if(NOT from STREQUAL "core" AND NOT from IN_LIST _layers)
    string(APPEND _errors "  ${f}: unknown layer '${from}' (add it to cmake/check_layout.cmake)\n")
    continue()
  endif()
  file(STRINGS "${GATCORE_ROOT}/${f}" _incs REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<][^\">]+[\">]")
  foreach(line IN LISTS _incs)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*[\"<]([^\">]+)[\">].*$" "\\1" inc "${line}")
    _layer_of("${inc}" to)
    if(to STREQUAL "" OR to STREQUAL "core")
      continue()
    endif()
    math(EXPR _checked "${_checked} + 1")
    if(to STREQUAL "loose")
      string(APPEND _errors "  ${f}: #include \"${inc}\" is outside any layer folder\n")
    elseif(NOT to IN_LIST _allowed_${from})
      string(APPEND _errors "  ${f} (${from}): #include \"${inc}\" (${to}) runs against the layer order\n")
    endif()
  endforeach()
endforeach()

if(_errors)
  message(FATAL_ERROR "check_layout: dependency direction violated:\n${_errors}")
endif()
if(_checked EQUAL 0)
  message(FATAL_ERROR "check_layout: no character-pipeline #include found under ${GATCORE_ROOT}: wrong root?")
endif()
message(STATUS "check_layout: ${_checked} character-pipeline includes follow the layer order")
