# ctest Python.installed: `cmake --install --component python` into a
# scratch prefix, then pytest test_installed.py with nothing but that
# prefix's dist-packages on PYTHONPATH, from a folder outside the build
# tree: the import a user has after installing.
#   cmake -DBUILD_DIR= -DSOURCE_DIR= -DWORK_DIR= -DPYTHON= -DPYTHON_VERSION= -DCLI= -P install_test.cmake
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR PYTHON PYTHON_VERSION CLI)
  if(NOT ${var})
    message(FATAL_ERROR "install_test.cmake: -D${var}= is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/run)
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} --component python
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install --component python failed (${rc}):\n${out}\n${err}")
endif()
set(site ${prefix}/lib/python${PYTHON_VERSION}/dist-packages)
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${site} ROCKLAB_INSTALLED_SITE=${site} ROCKLAB_CLI=${CLI}
          ROCKLAB_SOURCE_DIR=${SOURCE_DIR} PYTHONDONTWRITEBYTECODE=1
          ${PYTHON} -m pytest -q -p no:cacheprovider --rootdir=${WORK_DIR}/run --basetemp=${WORK_DIR}/tmp
          ${SOURCE_DIR}/tests/python/test_installed.py
  WORKING_DIRECTORY ${WORK_DIR}/run
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pytest test_installed.py failed (${rc})")
endif()
