# npm packages at build time, into the build tree (never the source tree),
# pinned by the package-lock.json next to the package.json.
#
#   rocklab_npm_ci(<source dir> <build dir> <comment> [BYPRODUCTS files...])
#
# copies package.json and package-lock.json to <build dir>, runs `npm ci`
# there, and touches <build dir>/npm-ci.stamp: depend on that file.
find_program(ROCKLAB_NPM npm)

function(rocklab_npm_ci src build comment)
  cmake_parse_arguments(arg "" "" "BYPRODUCTS" ${ARGN})
  if(NOT ROCKLAB_NPM)
    message(FATAL_ERROR
      "rocklab: npm not found, needed for ${comment}. Install Node.js and npm "
      "(tools/setup.sh does: apt-get install nodejs npm), or set ROCKLAB_NPM=/path/to/npm.")
  endif()
  add_custom_command(
    OUTPUT ${build}/npm-ci.stamp
    BYPRODUCTS ${arg_BYPRODUCTS}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${build}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${src}/package.json ${src}/package-lock.json ${build}
    COMMAND ${ROCKLAB_NPM} ci --ignore-scripts --no-audit --no-fund --loglevel=error
    COMMAND ${CMAKE_COMMAND} -E touch ${build}/npm-ci.stamp
    DEPENDS ${src}/package.json ${src}/package-lock.json
    WORKING_DIRECTORY ${build}
    COMMENT "npm ci: ${comment}"
    VERBATIM)
endfunction()
