# ctest: rocklab installs into a temporary prefix, and a fresh project
# (tests/package/consumer) finds it with find_package(rocklab), builds
# against the exported targets and runs. Proves: the config file finds every
# dependency (LCM without a CMake package), the targets carry their
# dependencies, every installed header compiles (one TU), share/rocklab
# holds the rig file the consumer reads.
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -P package_test.cmake
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "package_test.cmake: -D${var}= is required")
  endif()
endforeach()
set(prefix ${WORK_DIR}/prefix)
set(consumer_build ${WORK_DIR}/consumer)
file(REMOVE_RECURSE ${WORK_DIR})

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "package test: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "package test: ${what}: ok")
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(installed
    lib/cmake/rocklab/rocklabConfig.cmake lib/cmake/rocklab/rocklabTargets.cmake
    include/rocklab/model/fit.h include/rocklab/model/record.h
    include/rocklab/block_state_t.hpp
    share/rocklab/lcm_types/block_state_t.lcm share/rocklab/rigs/lab_rig.toml bin/rocklab)
  if(NOT EXISTS ${prefix}/${installed})
    message(FATAL_ERROR "package test: ${installed} is not installed")
  endif()
endforeach()
run("configure the consumer" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/package/consumer
    -B ${consumer_build} -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix})
run("build the consumer" ${CMAKE_COMMAND} --build ${consumer_build} -j 2)
run("run the consumer" ${consumer_build}/consumer ${prefix}/share/rocklab/rigs/lab_rig.toml)
message(STATUS "${last_output}")
file(REMOVE_RECURSE ${WORK_DIR})
