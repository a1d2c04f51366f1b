# Per-target warnings and sanitizers, shared by every rocklab target.
#
# ROCKLAB_SANITIZE: AddressSanitizer and UndefinedBehaviorSanitizer, except
#   -fno-sanitize=vptr: lcm-cpp (1.3.1) hands each subscription's handler
#   through a void* and casts it back to the handler's class inside the
#   library's template code; GCC 12's vptr check reports every such call
#   ("member call on address ... which does not point to an object of type")
#   and the node then dies in its first LCM callback, so with vptr on no
#   node test could run. The other UBSan checks (overflow, shifts, bounds,
#   float-cast-overflow, ...) stay on. Nothing else is turned off.
# ROCKLAB_FUZZ (clang): every library also carries libFuzzer's coverage
#   instrumentation (-fsanitize=fuzzer-no-link), so the fuzz targets in
#   tests/fuzz see into the libraries they call. Executables (the tests, the
#   command) are not fuzzed and go without it: ~15 % of their compile time.
function(rocklab_configure_target target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
  if(ROCKLAB_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(ROCKLAB_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize=vptr
                                             -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize=vptr)
  endif()
  get_target_property(type ${target} TYPE)
  if(ROCKLAB_FUZZ AND NOT type STREQUAL "EXECUTABLE")
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# rocklab_glue_code(target): code whose speed no test depends on (the
# tests' own files, the command's option handling and output). The
# sanitizer build compiles it at -O0 (clang with ASan: about half the CPU
# of -O1), while the libraries it calls keep the build type's flags
# (docs/testing.md, "Build time").
function(rocklab_glue_code target)
  if(ROCKLAB_SANITIZE)
    target_compile_options(${target} PRIVATE -O0)
  endif()
endfunction()

# rocklab_position_independent(target): a static library that goes into a
# shared object (a plugin, the Python module) and the static libraries it
# links, compiled position-independent (-fPIC instead of the executables'
# -fPIE). Only those: the executables and tests keep their flags.
function(rocklab_position_independent target)
  get_target_property(aliased ${target} ALIASED_TARGET)
  if(aliased)
    set(target ${aliased})
  endif()
  get_target_property(type ${target} TYPE)
  get_target_property(imported ${target} IMPORTED)
  if(imported OR NOT type STREQUAL "STATIC_LIBRARY")
    return()
  endif()
  get_target_property(done ${target} ROCKLAB_PIC)
  if(done)
    return()
  endif()
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON ROCKLAB_PIC ON)
  get_target_property(deps ${target} LINK_LIBRARIES)
  foreach(dep IN LISTS deps)
    if(TARGET ${dep})
      rocklab_position_independent(${dep})
    endif()
  endforeach()
endfunction()

# rocklab_add_plugin(target file COMPONENT component SOURCES ... LIBS ...):
# a plugin of the rocklab command (common/plugin.h), the shared object
# lib/rocklab/plugins/<file>.so in the build tree as installed, opened only by the
# commands that need it. The static libraries it links are copied into it
# and hidden (--exclude-libs): the plugin and the command each call their
# own copy; only the entry function (extern "C", default visibility) is
# exported. The rocklab target depends on every plugin (tools/), so what
# runs the command has them built.
function(rocklab_add_plugin target file)
  cmake_parse_arguments(PLUGIN "" "COMPONENT" "SOURCES;LIBS" ${ARGN})
  add_library(${target} MODULE ${PLUGIN_SOURCES})
  set_target_properties(${target} PROPERTIES OUTPUT_NAME ${file} PREFIX "" SUFFIX ".so"
    LIBRARY_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib/rocklab/plugins
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  target_include_directories(${target} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${target} PRIVATE ${PLUGIN_LIBS})
  foreach(lib IN LISTS PLUGIN_LIBS)
    if(TARGET ${lib})
      rocklab_position_independent(${lib})
    endif()
  endforeach()
  target_link_options(${target} PRIVATE LINKER:--exclude-libs,ALL)
  if(NOT ROCKLAB_SANITIZE AND NOT ROCKLAB_FUZZ)
    # Every symbol resolved at link time (the sanitizers' runtime is the
    # executable's, so their plugins keep those undefined).
    target_link_options(${target} PRIVATE LINKER:--no-undefined)
  endif()
  rocklab_configure_target(${target})
  # (A folder below lib/rocklab: CPack's .deb adds ldconfig calls to the
  # maintainer scripts for any shared object directly in a folder of
  # /usr/lib, which lintian rejects for plugins.)
  install(TARGETS ${target} LIBRARY DESTINATION lib/rocklab/plugins COMPONENT ${PLUGIN_COMPONENT})
  set_property(GLOBAL APPEND PROPERTY ROCKLAB_PLUGINS ${target})
endfunction()
