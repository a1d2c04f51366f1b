# Installing rocklab as a CMake package and a Debian package.
#
# find_package(rocklab): rocklabConfig.cmake (cmake/rocklabConfig.cmake.in)
# finds the dependencies as this build does, then includes the exported
# targets, named after their folder: rocklab::model, rocklab::daq, ...
# (EXPORT_NAME below). rocklab::export and rocklab::sweep were installed as
# rocklab::rocklab_export and rocklab::rocklab_sweep before issue 24: the
# config file keeps those names as aliases.
#
# CPack: `cd build && cpack -G DEB` makes rocklab_<version>_<arch>.deb with
# the binary, the static libraries, the headers (incl. the generated LCM
# headers), the CMake package, share/rocklab (the .lcm files, the lcm-spy
# jar, the lab rig file and sample tests) and every packaging/systemd/*.service
# and *.timer present when CMake configures.
include(CMakePackageConfigHelpers)

set(ROCKLAB_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/rocklab)
set(ROCKLAB_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/rocklab)

foreach(folder lcm common lcmtypes model daq compare monitor report pipeline record export sweep tools)
  if(TARGET rocklab_${folder})
    set_target_properties(rocklab_${folder} PROPERTIES EXPORT_NAME ${folder})
  endif()
endforeach()

install(EXPORT rocklabTargets NAMESPACE rocklab:: DESTINATION ${ROCKLAB_INSTALL_CMAKEDIR})
# What the config file must find again for the static libraries' links.
set(ROCKLAB_PACKAGE_MPI ${ROCKLAB_MPI})
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
install(FILES ${rocklab_lcm_files} DESTINATION ${ROCKLAB_INSTALL_DATADIR}/lcm_types)
# (the jar: lcm_types/CMakeLists.txt installs it as share/rocklab/rocklab_lcmtypes.jar)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/rigs DESTINATION ${ROCKLAB_INSTALL_DATADIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/samples DESTINATION ${ROCKLAB_INSTALL_DATADIR})

# systemd units: whatever packaging/systemd holds (written by the DAQ
# service work), picked up by a glob so a new unit needs no edit here.
file(GLOB ROCKLAB_SYSTEMD_UNITS CONFIGURE_DEPENDS
  ${PROJECT_SOURCE_DIR}/packaging/systemd/*.service
  ${PROJECT_SOURCE_DIR}/packaging/systemd/*.timer
  ${PROJECT_SOURCE_DIR}/packaging/systemd/*.socket)
if(ROCKLAB_SYSTEMD_UNITS)
  install(FILES ${ROCKLAB_SYSTEMD_UNITS} DESTINATION lib/systemd/system)
endif()

set(CPACK_PACKAGE_NAME rocklab)
set(CPACK_PACKAGE_VENDOR "rocklab")
set(CPACK_PACKAGE_CONTACT "rocklab <dev@rocklab>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
  "shake-table rocking-block lab: acquisition, CVODE models, live comparison, reports")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
# dpkg-shlibdeps finds the shared libraries the binary needs (liblcm,
# libsundials, libspdlog, libmicrohttpd, ...); the rest are for the headers
# and lcm-spy.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "gnuplot-nox, liblcm-bin, liblcm-java, libjchart2d-java, default-jre-headless")
# The Python module (python/, under /usr/lib/python3/dist-packages): built
# for this Python minor version, with numpy.
if(ROCKLAB_PYTHON)
  string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS
    ", python3 (>= ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}), python3 (<< ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}.99), python3-numpy")
endif()
set(CPACK_DEBIAN_PACKAGE_SUGGESTS
  "liblcm-dev, libsundials-dev, libeigen3-dev, libspdlog-dev, libcli11-dev, libtomlplusplus-dev, nlohmann-json3-dev, libmicrohttpd-dev")
include(CPack)
