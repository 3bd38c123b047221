# `cpack -G DEB` in the build directory (`make package`): tracemesh_<version>_<arch>.deb with both programs, the man
# pages, the docs and tracemeshd's systemd unit. dpkg-shlibdeps (Debian dpkg-dev) derives Depends from the binaries.
set(CPACK_PACKAGE_NAME tracemesh)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "the tracemesh authors")
set(CPACK_PACKAGE_CONTACT "the tracemesh authors")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "molecular Gaussian surface mesher (TMSmesh) and its HTTP service")
set(CPACK_PACKAGE_DESCRIPTION
    "tracemesh meshes the Gaussian surface of a molecule (PQR, PDB, mmCIF or xyzr) with the trace technique of \
TMSmesh into a closed, certified triangle mesh (OFF, PLY, GLB, Draco or MSMS): the command-line mesher tracemesh \
and the HTTP meshing service tracemeshd with its systemd unit.")
# The default component only: the Python package (component python) is not part of the .deb of the two programs,
# whose Depends would otherwise miss python3-numpy.
set(CPACK_INSTALL_CMAKE_PROJECTS "${CMAKE_BINARY_DIR};tracemesh;Unspecified;/")
set(CPACK_STRIP_FILES ON)  # the programs without their symbol tables: a third of the package
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
# Installed under /usr with DESTDIR, so the absolute /etc/default/tracemeshd of cmake/install_service.cmake lands
# in the package and not on the building machine.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "the tracemesh authors")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/debian/conffiles ${PROJECT_SOURCE_DIR}/packaging/debian/postinst
    ${PROJECT_SOURCE_DIR}/packaging/debian/prerm ${PROJECT_SOURCE_DIR}/packaging/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
