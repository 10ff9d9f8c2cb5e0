# The Vulkan compute backend (src/backends/vulkan/ with its shaders/), included by the top-level
# CMakeLists.txt after the gatcore_core target exists.
#
# GATCORE_VULKAN=AUTO builds it when the Vulkan headers/loader and
# glslangValidator are found, ON requires them, OFF skips it. Every
# shaders/*.comp is compiled to SPIR-V at build time (one custom command per
# shader; glslangValidator's depfile tracks the shaders/*.glsl it includes) and
# embedded in the library as uint32_t arrays (a generated .cpp), each in a
# descriptor variant and a buffer-device-address variant (<name>_bda).
set(GATCORE_HAVE_VULKAN OFF)
set(GATCORE_CONFIG_FIND_VULKAN OFF)
string(TOUPPER "${GATCORE_VULKAN}" _gatcore_vk_mode)
if(NOT _gatcore_vk_mode STREQUAL "OFF")
  find_package(Vulkan QUIET)
  find_program(GATCORE_GLSLANG_VALIDATOR NAMES glslangValidator)
  if(Vulkan_FOUND AND GATCORE_GLSLANG_VALIDATOR)
    set(GATCORE_HAVE_VULKAN ON)
  elseif(_gatcore_vk_mode STREQUAL "ON")
    message(FATAL_ERROR "GATCORE_VULKAN=ON but Vulkan (found: ${Vulkan_FOUND}) or glslangValidator "
                        "(${GATCORE_GLSLANG_VALIDATOR}) is missing; install libvulkan-dev and glslang-tools")
  else()
    message(STATUS "gatcore: Vulkan backend disabled (Vulkan or glslangValidator not found)")
  endif()
endif()

if(GATCORE_HAVE_VULKAN)
  message(STATUS "gatcore: Vulkan backend enabled (${GATCORE_GLSLANG_VALIDATOR})")
  file(GLOB _gatcore_vk_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/backends/vulkan/*.cpp)
  list(FILTER _gatcore_vk_sources EXCLUDE REGEX "/vulkan_stub\\.cpp$")
  file(GLOB _gatcore_shaders CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/backends/vulkan/shaders/*.comp)
  set(_spv_dir ${PROJECT_BINARY_DIR}/shaders)
  file(MAKE_DIRECTORY ${_spv_dir})
  set(_incs "")
  set(_table "")
  # Two variants per shader from one source (shaders/elementwise.glsl):
  # <name> binds descriptors, <name>_bda reaches its buffers through device
  # addresses (for operands past maxStorageBufferRange).
  foreach(_shader ${_gatcore_shaders})
    get_filename_component(_base ${_shader} NAME_WE)
    foreach(_variant "" "_bda")
      set(_name ${_base}${_variant})
      set(_defs -DELEM=float)
      if(_variant STREQUAL "_bda")
        list(APPEND _defs -DGATCORE_BDA)
      endif()
      set(_out ${_spv_dir}/${_name}.spv.inc)
      add_custom_command(
        OUTPUT ${_out}
        COMMAND ${GATCORE_GLSLANG_VALIDATOR} -V --target-env vulkan1.1 ${_defs}
                -I${PROJECT_SOURCE_DIR}/src/backends/vulkan/shaders --vn gatcore_spv_${_name} --depfile ${_spv_dir}/${_name}.d
                -o ${_out} ${_shader}
        DEPENDS ${_shader}
        DEPFILE ${_spv_dir}/${_name}.d
        COMMENT "glslang: shaders/${_base}.comp ${_defs}"
        VERBATIM)
      list(APPEND _incs ${_out})
      string(APPEND _gatcore_vk_includes "#include \"shaders/${_name}.spv.inc\"\n")
      string(APPEND _gatcore_vk_table "    {\"${_name}\", gatcore_spv_${_name}, sizeof(gatcore_spv_${_name}) / 4},\n")
    endforeach()
  endforeach()
  set(GATCORE_VK_SHADER_INCLUDES "${_gatcore_vk_includes}")
  set(GATCORE_VK_SHADER_TABLE "${_gatcore_vk_table}")
  configure_file(${PROJECT_SOURCE_DIR}/src/backends/vulkan/shaders_embedded.cpp.in ${_spv_dir}/shaders_embedded.cpp @ONLY)
  set_source_files_properties(${_spv_dir}/shaders_embedded.cpp PROPERTIES OBJECT_DEPENDS "${_incs}")
  target_sources(gatcore_core PRIVATE ${_gatcore_vk_sources} ${_spv_dir}/shaders_embedded.cpp ${_incs})
  target_include_directories(gatcore_core PRIVATE ${PROJECT_BINARY_DIR})
  target_link_libraries(gatcore_core PRIVATE Vulkan::Vulkan)
  target_compile_definitions(gatcore_core PUBLIC GATCORE_HAS_VULKAN=1)
  get_target_property(_gatcore_type gatcore_core TYPE)
  if(_gatcore_type STREQUAL "STATIC_LIBRARY")
    set(GATCORE_CONFIG_FIND_VULKAN ON)
  endif()
endif()
