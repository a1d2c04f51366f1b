# ctest rocklab_package_deb: the .debs CPack makes from this build
# (cmake/RocklabPackage.cmake), checked as Debian would: lintian passes
# (--pedantic --info shown; errors and warnings fail the test), each
# package holds what docs/packaging.md says and only that, every systemd
# unit's Documentation= file is in the package, Depends names the shared
# libraries the binary and its MPI plugin link (HDF5, matio, OpenMPI among
# them) and not OpenCV, which is rocklab-video's (with VIDEO: its plugin,
# its Depends on OpenCV and on rocklab of the same version).
#   cmake -DBUILD_DIR=... -DWORK_DIR=... [-DVIDEO=ON] [-DMPI=ON] [-DSUNDIALS_STATIC=ON] -P deb_test.cmake
foreach(var BUILD_DIR WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "deb_test.cmake: -D${var}= is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "deb test: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

function(fail_or_skip why)
  if("$ENV{CI}" STREQUAL "true")
    message(FATAL_ERROR "deb test: CI=true: may not skip: ${why}")
  endif()
  message(STATUS "rocklab-skip: ${why}")
endfunction()

get_filename_component(cmake_bin ${CMAKE_COMMAND} DIRECTORY)
run("cpack" ${cmake_bin}/cpack -G DEB --config ${BUILD_DIR}/CPackConfig.cmake -B ${WORK_DIR})
file(GLOB main_deb ${WORK_DIR}/rocklab_*.deb)
file(GLOB dev_deb ${WORK_DIR}/rocklab-dev_*.deb)
if(NOT main_deb OR NOT dev_deb)
  message(FATAL_ERROR "deb test: expected rocklab_*.deb and rocklab-dev_*.deb in ${WORK_DIR}")
endif()
file(GLOB video_deb ${WORK_DIR}/rocklab-video_*.deb)
if(VIDEO AND NOT video_deb)
  message(FATAL_ERROR "deb test: expected rocklab-video_*.deb in ${WORK_DIR} (a build with ROCKLAB_VIDEO)")
endif()
if(NOT VIDEO AND video_deb)
  message(FATAL_ERROR "deb test: rocklab-video_*.deb from a build without ROCKLAB_VIDEO")
endif()

# The sizes docs/packaging.md quotes, printed for measuring again.
foreach(deb ${main_deb} ${dev_deb} ${video_deb})
  file(SIZE ${deb} bytes)
  run("dpkg-deb -f" dpkg-deb -f ${deb} Installed-Size)
  string(STRIP "${last_output}" installed)
  get_filename_component(name ${deb} NAME)
  message(STATUS "deb test: ${name}: ${bytes} bytes, Installed-Size ${installed} KiB")
endforeach()

run("dpkg-deb -c rocklab" dpkg-deb -c ${main_deb})
set(main_files "${last_output}")
run("dpkg-deb -c rocklab-dev" dpkg-deb -c ${dev_deb})
set(dev_files "${last_output}")
run("dpkg-deb -f rocklab" dpkg-deb -f ${main_deb} Depends Maintainer)
set(main_control "${last_output}")

# What each package holds (docs/packaging.md's table).
# require_paths(PACKAGE LISTING PATH...): dpkg-deb -c's LISTING holds each PATH.
function(require_paths package listing)
  foreach(path ${ARGN})
    string(FIND "${listing}" " ${path}\n" at)
    if(at EQUAL -1)
      message(FATAL_ERROR "deb test: ${package} lacks ${path}")
    endif()
  endforeach()
endfunction()
require_paths(rocklab "${main_files}" ./usr/bin/rocklab ./usr/share/man/man1/rocklab.1.gz
  ./usr/share/doc/rocklab/copyright ./usr/share/doc/rocklab/changelog.Debian.gz ./usr/share/doc/rocklab/README.md
  ./usr/share/rocklab/rigs/lab_rig.toml ./usr/share/rocklab/lcm_types/block_state_t.lcm
  ./usr/lib/systemd/system/rocklab-daq.service ./usr/lib/rocklab/plugins/rocklab-hdf5.so
  ./usr/lib/rocklab/plugins/rocklab-monitor.so ./usr/share/bash-completion/completions/rocklab)
require_paths(rocklab-dev "${dev_files}" ./usr/include/rocklab/model/block.h
  ./usr/include/rocklab/block_state_t.hpp ./usr/lib/librocklab_model.a ./usr/lib/librocklab_sweep.a
  ./usr/lib/cmake/rocklab/rocklabConfig.cmake ./usr/share/doc/rocklab-dev/copyright
  ./usr/share/doc/rocklab-dev/changelog.Debian.gz)
if(main_files MATCHES "/usr/include/|\\.a\n|/lib/cmake/")
  message(FATAL_ERROR "deb test: rocklab holds headers, static libraries or CMake files (rocklab-dev's)")
endif()
if(dev_files MATCHES "/usr/bin/|\\.service\n")
  message(FATAL_ERROR "deb test: rocklab-dev holds the command or units (rocklab's)")
endif()

# Every unit's Documentation=file:///... is in the package.
run("extract rocklab" dpkg-deb -x ${main_deb} ${WORK_DIR}/root)
file(GLOB units ${WORK_DIR}/root/usr/lib/systemd/system/*.service)
list(LENGTH units n_units)
if(n_units EQUAL 0)
  message(FATAL_ERROR "deb test: no systemd unit in rocklab")
endif()
foreach(unit ${units})
  file(STRINGS ${unit} docs REGEX "^Documentation=")
  foreach(line ${docs})
    string(REGEX MATCHALL "file://[^ ]+" urls "${line}")
    foreach(url ${urls})
      string(REPLACE "file://" "" path "${url}")
      if(NOT EXISTS ${WORK_DIR}/root${path})
        message(FATAL_ERROR "deb test: ${unit} points at ${url}, which the package does not hold")
      endif()
    endforeach()
  endforeach()
endforeach()

# Depends: dpkg-shlibdeps's libraries of the binary. SUNDIALS' shared
# libraries only where they are linked (-DSUNDIALS_STATIC=ON: the command,
# the plugins and the Python module hold its static archives, and no
# libsundials package may be named).
set(main_deps libhdf5 libmatio libopenmpi liblcm1 libmicrohttpd gnuplot-nox)
if(SUNDIALS_STATIC)
  if(main_control MATCHES "libsundials")
    message(FATAL_ERROR "deb test: SUNDIALS is linked statically, yet Depends of rocklab names it:\n${main_control}")
  endif()
else()
  list(APPEND main_deps libsundials-cvode)
endif()
foreach(dep ${main_deps})
  string(FIND "${main_control}" "${dep}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "deb test: Depends of rocklab lacks ${dep}:\n${main_control}")
  endif()
endforeach()
if(MPI)
  require_paths(rocklab "${main_files}" ./usr/lib/rocklab/plugins/rocklab-mpi.so)
endif()
if(main_control MATCHES "libopencv" OR main_files MATCHES "rocklab-video")
  message(FATAL_ERROR "deb test: rocklab holds or depends on the video part (rocklab-video's):\n${main_control}")
endif()
if(VIDEO)
  run("dpkg-deb -c rocklab-video" dpkg-deb -c ${video_deb})
  set(video_files "${last_output}")
  run("dpkg-deb -f rocklab-video" dpkg-deb -f ${video_deb} Depends)
  set(video_control "${last_output}")
  require_paths(rocklab-video "${video_files}" ./usr/lib/rocklab/plugins/rocklab-video.so
    ./usr/share/doc/rocklab-video/copyright)
  if(video_files MATCHES "/usr/bin/|/usr/include/")
    message(FATAL_ERROR "deb test: rocklab-video holds the command or headers")
  endif()
  foreach(dep "rocklab (= " libopencv-videoio libopencv-core)
    string(FIND "${video_control}" "${dep}" at)
    if(at EQUAL -1)
      message(FATAL_ERROR "deb test: Depends of rocklab-video lacks ${dep}:\n${video_control}")
    endif()
  endforeach()
endif()
if(main_control MATCHES "<dev@rocklab>")
  message(FATAL_ERROR "deb test: Maintainer is the placeholder dev@rocklab")
endif()

find_program(LINTIAN lintian)
if(NOT LINTIAN)
  fail_or_skip("lintian not installed (apt-get install lintian; tools/setup.sh with ROCKLAB_TEST_TOOLS=1)")
  return()
endif()
execute_process(COMMAND ${LINTIAN} --pedantic --info --fail-on error,warning ${main_deb} ${dev_deb} ${video_deb}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCHALL "(^|\n)[EWIPX]: [^\n]*" tags "${out}")
list(LENGTH tags n_tags)
message(STATUS "deb test: lintian --pedantic --info: ${n_tags} tags${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "deb test: lintian reports errors or warnings (${rc}):\n${out}\n${err}")
endif()
file(REMOVE_RECURSE ${WORK_DIR})
message(STATUS "deb test: rocklab, rocklab-dev (and rocklab-video) hold what they should; lintian passes")
