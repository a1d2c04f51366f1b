# CPack pre-build script (CPACK_PRE_BUILD_SCRIPTS): strips what CPack
# staged, as Debian's dh_strip does, before the .debs are made: ELF
# executables and shared objects lose their debug information and symbols
# nobody links against (--strip-unneeded), static libraries only their
# debug information (--strip-debug: the symbol table stays, so they still
# link), both lose .comment and .note; ELF files lose their RUNPATH. The build tree keeps its debug
# information (RelWithDebInfo); only the packages are stripped.
find_program(ROCKLAB_STRIP strip REQUIRED)
file(GLOB_RECURSE staged LIST_DIRECTORIES false "${CPACK_TEMPORARY_DIRECTORY}/*")
foreach(f ${staged})
  if(IS_SYMLINK "${f}")
    continue()
  endif()
  file(READ "${f}" magic LIMIT 8 HEX)
  if(f MATCHES "\\.a$" AND magic STREQUAL "213c617263683e0a")  # "!<arch>\n"
    execute_process(COMMAND ${ROCKLAB_STRIP} --strip-debug --remove-section=.comment --remove-section=.note
                            --enable-deterministic-archives "${f}" RESULT_VARIABLE rc)
  elseif(magic MATCHES "^7f454c46")  # ELF
    # The build tree's RUNPATH (the Python module carries HDF5's and
    # OpenMPI's -dev folders) is not wanted installed: their runtime
    # libraries are in the linker's own path.
    file(RPATH_REMOVE FILE "${f}")
    execute_process(COMMAND ${ROCKLAB_STRIP} --strip-unneeded --remove-section=.comment --remove-section=.note
                            "${f}" RESULT_VARIABLE rc)
  else()
    continue()
  endif()
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "strip.cmake: strip failed on ${f}")
  endif()
endforeach()
