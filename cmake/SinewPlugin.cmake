# sinew_add_plugin(): declares one Sinew plugin. The plugin's sources define one registration
# function; this generates the entry point around it (cmake/sinew_plugin_entry.cpp.in), so no
# plugin writes loader boilerplate by hand. Used for the built-in plugins (STATIC) and, installed
# with the SDK, by third parties (find_package(Sinew REQUIRED COMPONENTS pluginsdk)).
#
#   sinew_add_plugin(NAME balloon KIND force REGISTER registerBalloonForce
#                    SOURCES balloon_force.cpp [balloon_kernels.cu]
#                    [VERSION 1.0.0] [SUMMARY "one line"] [STATIC])
#
# KIND: force, integrator, image-io, mesh-io or tool. REGISTER names a function in namespace sinew:
# void REGISTER(sinew::Registry&), or void REGISTER(sinew::ToolRegistry&) for tools.
# Without STATIC: a MODULE library `NAME` written as sinew-plugin-NAME.so, exporting only its two
# extern "C" entry points; put it in a plugin directory (or SINEW_PLUGIN_PATH) to load it.
# With STATIC: a static library sinew_plugin_NAME whose entry point is sinew_plugin_info_NAME(),
# for a program to link in and hand to PluginLoader::addBuiltin().
function(sinew_add_plugin)
  cmake_parse_arguments(P "STATIC" "NAME;KIND;REGISTER;VERSION;SUMMARY" "SOURCES" ${ARGN})
  if(NOT P_NAME OR NOT P_NAME MATCHES "^[a-z][a-z0-9_]*$")
    message(FATAL_ERROR "sinew_add_plugin: NAME '${P_NAME}' must be lower-case letters, digits and _")
  endif()
  if(NOT P_REGISTER OR NOT P_SOURCES)
    message(FATAL_ERROR "sinew_add_plugin(${P_NAME}): REGISTER and SOURCES are required")
  endif()
  set(_kinds force Force integrator Integrator image-io ImageIO mesh-io MeshIO tool Tool)
  list(FIND _kinds "${P_KIND}" _at)
  math(EXPR _odd "${_at} % 2")
  if(_at LESS 0 OR _odd)
    message(FATAL_ERROR "sinew_add_plugin(${P_NAME}): KIND '${P_KIND}' is not one of force, integrator, image-io, mesh-io, tool")
  endif()
  math(EXPR _at "${_at} + 1")
  list(GET _kinds ${_at} SINEW_PLUGIN_KIND)
  if(NOT P_VERSION)
    set(P_VERSION "${PROJECT_VERSION}")
  endif()
  set(SINEW_PLUGIN_NAME "${P_NAME}")
  set(SINEW_PLUGIN_VERSION "${P_VERSION}")
  string(REPLACE "\"" "\\\"" SINEW_PLUGIN_SUMMARY "${P_SUMMARY}")
  set(SINEW_PLUGIN_REGISTER "${P_REGISTER}")
  if(P_KIND STREQUAL "tool")
    # Tools register into a scratch registry merged only when complete, as the loader does for the
    # engine's components (the loader cannot: ToolRegistry is the workstation's type).
    set(SINEW_PLUGIN_INCLUDE "#include \"interaction_tool.h\"")
    set(SINEW_PLUGIN_REGISTRY ToolRegistry)
    set(SINEW_PLUGIN_CALL "if (!host.tools) return;\n  sinew::ToolRegistry scratch;\n  sinew::${P_REGISTER}(scratch);\n  host.tools->merge(std::move(scratch));")
  else()
    set(SINEW_PLUGIN_INCLUDE "")
    set(SINEW_PLUGIN_REGISTRY Registry)
    set(SINEW_PLUGIN_CALL "sinew::${P_REGISTER}(host.registry);")
  endif()
  if(P_STATIC)
    set(SINEW_PLUGIN_LINKAGE "")
    set(SINEW_PLUGIN_INFO_FN "sinew_plugin_info_${P_NAME}")
    set(SINEW_PLUGIN_ABI_FN "sinew_plugin_abi_version_${P_NAME}")
    set(_target sinew_plugin_${P_NAME})
  else()
    set(SINEW_PLUGIN_LINKAGE "extern \"C\" __attribute__((visibility(\"default\")))")
    set(SINEW_PLUGIN_INFO_FN "sinew_plugin_info")
    set(SINEW_PLUGIN_ABI_FN "sinew_plugin_abi_version")
    set(_target ${P_NAME})
  endif()
  set(_entry "${CMAKE_CURRENT_BINARY_DIR}/sinew_plugin_entry_${P_NAME}.cpp")
  configure_file("${CMAKE_CURRENT_FUNCTION_LIST_DIR}/sinew_plugin_entry.cpp.in" "${_entry}" @ONLY)
  if(P_STATIC)
    add_library(${_target} STATIC ${P_SOURCES} "${_entry}")
  else()
    add_library(${_target} MODULE ${P_SOURCES} "${_entry}")
    # Only the entry points leave the library: two plugins never clash on their internal names.
    set_target_properties(${_target} PROPERTIES PREFIX "" OUTPUT_NAME "sinew-plugin-${P_NAME}" SUFFIX ".so"
      CXX_VISIBILITY_PRESET hidden CUDA_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  endif()
  target_link_libraries(${_target} PUBLIC Sinew::core)
  # No fused multiply-add on the CPU (Sinew's own rule): with --fmad=false kernels, a force's CPU
  # and CUDA paths then round alike.
  target_compile_options(${_target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-ffp-contract=off>)
endfunction()

# sinew_add_plugin_test(NAME test_balloon PLUGIN balloon SOURCES test_balloon.cpp): a Qt Test
# program for a plugin, registered with CTest. It links Sinew's engine and Qt Test, runs moc, and
# gets the plugin's file as SINEW_PLUGIN_FILE, for sinew/sdk/plugin_testing.h to load it exactly as
# Sinew does.
function(sinew_add_plugin_test)
  cmake_parse_arguments(T "" "NAME;PLUGIN" "SOURCES" ${ARGN})
  if(NOT T_NAME OR NOT T_PLUGIN OR NOT T_SOURCES)
    message(FATAL_ERROR "sinew_add_plugin_test: NAME, PLUGIN and SOURCES are required")
  endif()
  find_package(Qt6 REQUIRED COMPONENTS Test)
  add_executable(${T_NAME} ${T_SOURCES})
  set_target_properties(${T_NAME} PROPERTIES AUTOMOC ON)
  target_link_libraries(${T_NAME} PRIVATE Sinew::core Qt6::Test)
  if(TARGET Sinew::plugin_testing)
    target_link_libraries(${T_NAME} PRIVATE Sinew::plugin_testing)
  endif()
  target_compile_definitions(${T_NAME} PRIVATE SINEW_PLUGIN_FILE="$<TARGET_FILE:${T_PLUGIN}>" QT_NO_KEYWORDS)
  add_dependencies(${T_NAME} ${T_PLUGIN})
  add_test(NAME ${T_NAME} COMMAND ${T_NAME})
endfunction()
