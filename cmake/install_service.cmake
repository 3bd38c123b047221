# Run by `cmake --install` (install(SCRIPT) of cmake/install.cmake): writes tracemeshd.service for the install
# prefix and installs it with the defaults file tracemeshd reads. As GNUInstallDirs does for the configuration
# directory, prefix /usr (the Debian package) puts the defaults in /etc/default, any other prefix P in P/etc/default.
# The unit goes to P/lib/systemd/system (/usr/lib/systemd/system for the package: Debian 12 merges /lib into /usr).
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(_tm_etc_dir /etc)
else()
  set(_tm_etc_dir "${CMAKE_INSTALL_PREFIX}/etc")
endif()
set(TRACEMESHD_PATH "${CMAKE_INSTALL_PREFIX}/${TRACEMESH_BINDIR}/tracemeshd")
set(TRACEMESHD_DEFAULTS "${_tm_etc_dir}/default/tracemeshd")
configure_file("${TRACEMESH_PACKAGING_DIR}/systemd/tracemeshd.service.in" "${TRACEMESH_STAGING_DIR}/tracemeshd.service"
               @ONLY)
file(INSTALL "${TRACEMESH_STAGING_DIR}/tracemeshd.service" DESTINATION "${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
file(INSTALL "${TRACEMESH_PACKAGING_DIR}/systemd/tracemeshd.default" DESTINATION "${_tm_etc_dir}/default"
     RENAME tracemeshd)
