# Installing rocklab as a CMake package and a Debian package.
#
# find_package(rocklab): rocklabConfig.cmake (cmake/rocklabConfig.cmake.in)
# finds the dependencies as this build does, then includes the exported
# targets, named after their folder: rocklab::model, rocklab::daq, ...
# (EXPORT_NAME below). rocklab::export and rocklab::sweep were installed as
# rocklab::rocklab_export and rocklab::rocklab_sweep in earlier versions: the
# config file keeps those names as aliases.
#
# CPack: `cd build && cpack -G DEB` makes rocklab and rocklab-dev (below).
include(CMakePackageConfigHelpers)

set(ROCKLAB_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/rocklab)
set(ROCKLAB_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/rocklab)

foreach(folder lcm common lcmtypes model daq compare monitor report pipeline record export sweep tools)
  if(TARGET rocklab_${folder})
    set_target_properties(rocklab_${folder} PROPERTIES EXPORT_NAME ${folder})
  endif()
endforeach()

install(EXPORT rocklabTargets NAMESPACE rocklab:: DESTINATION ${ROCKLAB_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/rocklabConfig.cmake.in
  ${PROJECT_BINARY_DIR}/rocklabConfig.cmake
  INSTALL_DESTINATION ${ROCKLAB_INSTALL_CMAKEDIR}
  PATH_VARS ROCKLAB_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/rocklabConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/rocklabConfig.cmake ${PROJECT_BINARY_DIR}/rocklabConfigVersion.cmake
  DESTINATION ${ROCKLAB_INSTALL_CMAKEDIR})

# share/rocklab: what lcm-spy, lcm-gen for other languages and a new user need.
file(GLOB rocklab_lcm_files CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/lcm_types/*.lcm)
install(FILES ${rocklab_lcm_files} DESTINATION ${ROCKLAB_INSTALL_DATADIR}/lcm_types COMPONENT runtime)
# (the jar: lcm_types/CMakeLists.txt installs it as share/rocklab/rocklab_lcmtypes.jar)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/rigs DESTINATION ${ROCKLAB_INSTALL_DATADIR} COMPONENT runtime)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/samples DESTINATION ${ROCKLAB_INSTALL_DATADIR} COMPONENT runtime)

# systemd units: whatever packaging/systemd holds, picked up by a glob so a
# new unit needs no edit here. Installed, not enabled.
file(GLOB ROCKLAB_SYSTEMD_UNITS CONFIGURE_DEPENDS
  ${PROJECT_SOURCE_DIR}/packaging/systemd/*.service
  ${PROJECT_SOURCE_DIR}/packaging/systemd/*.timer
  ${PROJECT_SOURCE_DIR}/packaging/systemd/*.socket)
if(ROCKLAB_SYSTEMD_UNITS)
  install(FILES ${ROCKLAB_SYSTEMD_UNITS} DESTINATION lib/systemd/system COMPONENT runtime)
endif()

# share/doc/rocklab: the guides (the units' Documentation= points at
# daq-inputs.md there), the README, and for each package the copyright and
# changelog.Debian.gz Debian asks for; share/man/man1/rocklab.1.gz made from
# `rocklab help` (packaging/manpage.cmake).
find_program(ROCKLAB_GZIP gzip REQUIRED)
set(rocklab_pkg_dir ${PROJECT_BINARY_DIR}/packaging)
add_custom_command(OUTPUT ${rocklab_pkg_dir}/changelog.Debian.gz
  COMMAND ${CMAKE_COMMAND} -E make_directory ${rocklab_pkg_dir}
  COMMAND ${CMAKE_COMMAND} -E copy ${PROJECT_SOURCE_DIR}/packaging/debian/changelog ${rocklab_pkg_dir}/changelog.Debian
  COMMAND ${ROCKLAB_GZIP} -9nf ${rocklab_pkg_dir}/changelog.Debian
  DEPENDS ${PROJECT_SOURCE_DIR}/packaging/debian/changelog
  COMMENT "changelog.Debian.gz for the packages" VERBATIM)
add_custom_command(OUTPUT ${rocklab_pkg_dir}/rocklab.1.gz
  COMMAND ${CMAKE_COMMAND} -E make_directory ${rocklab_pkg_dir}
  COMMAND ${CMAKE_COMMAND} -DROCKLAB=$<TARGET_FILE:rocklab> -DGZIP=${ROCKLAB_GZIP} -DOUT=${rocklab_pkg_dir}/rocklab.1.gz
    -P ${PROJECT_SOURCE_DIR}/packaging/manpage.cmake
  DEPENDS rocklab ${PROJECT_SOURCE_DIR}/packaging/manpage.cmake
  COMMENT "rocklab.1.gz from rocklab help" VERBATIM)
# Not in `all` for the Python module alone (ROCKLAB_PYTHON_ONLY): the man
# page needs the command built.
set(rocklab_package_docs_all ALL)
if(ROCKLAB_PYTHON_ONLY)
  set(rocklab_package_docs_all)
endif()
add_custom_target(rocklab_package_docs ${rocklab_package_docs_all}
  DEPENDS ${rocklab_pkg_dir}/changelog.Debian.gz ${rocklab_pkg_dir}/rocklab.1.gz)
install(FILES ${rocklab_pkg_dir}/rocklab.1.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT runtime)
file(GLOB rocklab_guides CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${rocklab_guides} DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/rocklab
  COMPONENT runtime)
# Lintian overrides: what lintian says that does not apply to a package
# that is not for the Debian archive (packaging/debian/*.lintian-overrides).
set(rocklab_doc_packages runtime:rocklab dev:rocklab-dev)
if(ROCKLAB_VIDEO)
  list(APPEND rocklab_doc_packages video:rocklab-video)
endif()
foreach(component_and_package ${rocklab_doc_packages})
  string(REPLACE ":" ";" pair ${component_and_package})
  list(GET pair 0 component)
  list(GET pair 1 package)
  install(FILES ${PROJECT_SOURCE_DIR}/packaging/debian/copyright ${rocklab_pkg_dir}/changelog.Debian.gz
    DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/${package} COMPONENT ${component})
  install(FILES ${PROJECT_SOURCE_DIR}/packaging/debian/${package}.lintian-overrides
    DESTINATION ${CMAKE_INSTALL_DATADIR}/lintian/overrides RENAME ${package} COMPONENT ${component})
endforeach()

# CPack: `cd build && cpack -G DEB` makes the packages, as Debian splits a
# library's: rocklab (the group "main": components runtime and python) with
# the command, its MPI plugin, units, data, docs and Python module,
# rocklab-dev (the component dev: every install() without a COMPONENT, see
# CMakeLists.txt) with the static libraries, headers and CMake package, and
# rocklab-video (the component video) with the video plugin
# lib/rocklab/plugins/rocklab-video.so, OpenCV's part, so that rocklab itself
# neither needs nor maps OpenCV. packaging/strip.cmake
# strips what they hold. docs/packaging.md: contents, sizes, lintian.
set(ROCKLAB_PACKAGE_MAINTAINER "rocklab developers <dev@rocklab.invalid>" CACHE STRING
  "Maintainer of the .deb packages (a real address before the package leaves the lab)")
set(CPACK_PACKAGE_NAME rocklab)
set(CPACK_PACKAGE_VENDOR "rocklab")
set(CPACK_PACKAGE_CONTACT "${ROCKLAB_PACKAGE_MAINTAINER}")
# (No CPACK_PACKAGE_DESCRIPTION_SUMMARY: each package's synopsis is the
# first line of its CPACK_DEBIAN_<GROUP>_DESCRIPTION below.)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)  # 0.1.0-1: a Debian revision (changelog.Debian)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_PRE_BUILD_SCRIPTS ${PROJECT_SOURCE_DIR}/packaging/strip.cmake)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ONE_PER_GROUP)
set(CPACK_COMPONENTS_ALL runtime dev)
if(ROCKLAB_PYTHON)
  list(APPEND CPACK_COMPONENTS_ALL python)
endif()
if(ROCKLAB_VIDEO)
  list(APPEND CPACK_COMPONENTS_ALL video)
endif()
set(CPACK_COMPONENT_RUNTIME_GROUP main)
set(CPACK_COMPONENT_PYTHON_GROUP main)
set(CPACK_COMPONENT_DEV_GROUP dev)
set(CPACK_COMPONENT_VIDEO_GROUP video)
set(CPACK_DEBIAN_MAIN_PACKAGE_NAME rocklab)
set(CPACK_DEBIAN_DEV_PACKAGE_NAME rocklab-dev)
set(CPACK_DEBIAN_VIDEO_PACKAGE_NAME rocklab-video)
set(CPACK_DEBIAN_MAIN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_VIDEO_PACKAGE_SECTION science)
set(CPACK_DEBIAN_MAIN_DESCRIPTION
 "shake-table rocking-block lab: acquisition, models, reports
rocklab runs a shake-table laboratory's rocking-block tests: it acquires
the rig's channels (LabVIEW files, TCP, LCM, video), reconstructs the
rocking angle, runs Housner's and the complex formulation's models beside
the experiment, records and replays LCM logs, sweeps ground-motion
records for overturning spectra and fragility, and writes reports and
exports (CSV, MAT, HDF5). This package holds the rocklab command, its
systemd units (installed, not enabled), the LCM types, sample tests and
the Python module.")
set(CPACK_DEBIAN_VIDEO_DESCRIPTION
 "shake-table rocking-block lab: video inputs and LED tracking
The plugin of the rocklab command that reads a camera's video (OpenCV,
FFmpeg): the video: and v4l2: inputs of rocklab daq, run and reconstruct,
and the commands rocklab track and rocklab camera-calibrate. Without it
rocklab runs everything else and names this package when a video input
is asked for.")
set(CPACK_DEBIAN_DEV_DESCRIPTION
 "shake-table rocking-block lab: static libraries and headers
The static libraries, headers and CMake package of rocklab, for programs
that use its models, acquisition or sweeps: find_package(rocklab) and
link rocklab::model, rocklab::daq, rocklab::sweep and the others.")
# dpkg-shlibdeps finds the shared libraries the binary and the MPI plugin
# need (liblcm, SUNDIALS, spdlog, HDF5, matio, OpenMPI, ...); the rest:
# gnuplot for figures, the LCM tools and Java for `rocklab spy`.
# rocklab-video: OpenCV's and FFmpeg's libraries (dpkg-shlibdeps on its plugin) and the
# rocklab of its version, whose command opens it.
set(CPACK_DEBIAN_MAIN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_VIDEO_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_VIDEO_PACKAGE_DEPENDS "rocklab (= ${PROJECT_VERSION}-1)")
if(ROCKLAB_VIDEO)
  set(CPACK_DEBIAN_MAIN_PACKAGE_SUGGESTS "rocklab-video")
endif()
# liblcm1 by name: the command opens liblcm.so.1 when it opens the bus
# (tools/lcm_forward.cpp), so dpkg-shlibdeps does not see it in its DT_NEEDED.
set(CPACK_DEBIAN_MAIN_PACKAGE_DEPENDS "gnuplot-nox, liblcm1, liblcm-bin, liblcm-java, libjchart2d-java, default-jre-headless")
# The Python module (python/, under /usr/lib/python3/dist-packages): built
# for this Python minor version, with numpy.
if(ROCKLAB_PYTHON)
  string(APPEND CPACK_DEBIAN_MAIN_PACKAGE_DEPENDS
    ", python3 (>= ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}), python3 (<< ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}.99), python3-numpy")
endif()
# rocklab-dev: what find_package(rocklab) finds (rocklabConfig.cmake), and
# the data directory of rocklab itself.
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
  "rocklab (= ${PROJECT_VERSION}-1), liblcm-dev, libsundials-dev, libeigen3-dev, libspdlog-dev, libcli11-dev, libtomlplusplus-dev, nlohmann-json3-dev, libmicrohttpd-dev, libhdf5-dev, libmatio-dev, pkg-config")
include(CPack)
