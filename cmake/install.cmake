# `cmake --install BUILD --prefix P`: P/bin/tracemesh and P/bin/tracemeshd (install rules next to their targets in
# cli/ and server/), the man pages, the documentation and tracemeshd's systemd unit and defaults (packaging/).
# Installing (and `cpack`) does not build the whole project first: `make install` and `make package` build just the
# two programs, and a build tree with the suite configured need not compile every test to make a package.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
install(FILES ${PROJECT_SOURCE_DIR}/packaging/man/tracemesh.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
install(FILES ${PROJECT_SOURCE_DIR}/packaging/man/tracemeshd.8 DESTINATION ${CMAKE_INSTALL_MANDIR}/man8)
# The machine-readable copyright file Debian expects in every package's documentation folder.
install(FILES ${PROJECT_SOURCE_DIR}/packaging/debian/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The documents are globbed when installing, not when configuring: docs/ grows without a re-configure. docs/ keeps
# its folder (its README.md is not the top-level one; its links to ../README.md and images/ stay valid).
install(CODE "
  file(GLOB _tm_docs \"${PROJECT_SOURCE_DIR}/README.md\" \"${PROJECT_SOURCE_DIR}/CHANGELOG.md\"
       \"${PROJECT_SOURCE_DIR}/LICENSE\" \"${PROJECT_SOURCE_DIR}/THIRD_PARTY.md\")
  file(INSTALL \${_tm_docs} DESTINATION \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_DOCDIR}\")
  file(GLOB _tm_pages \"${PROJECT_SOURCE_DIR}/docs/*.md\")
  file(GLOB _tm_images \"${PROJECT_SOURCE_DIR}/docs/images/*\")
  if(_tm_pages)
    file(INSTALL \${_tm_pages} DESTINATION \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_DOCDIR}/docs\")
  endif()
  if(_tm_images)
    file(INSTALL \${_tm_images} DESTINATION \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_DOCDIR}/docs/images\")
  endif()")
# The unit names the installed tracemeshd and its defaults file, known only at install time (the prefix of
# `cmake --install --prefix` or of CPack): cmake/install_service.cmake writes both then.
install(CODE "
  set(TRACEMESH_PACKAGING_DIR \"${PROJECT_SOURCE_DIR}/packaging\")
  set(TRACEMESH_BINDIR \"${CMAKE_INSTALL_BINDIR}\")
  set(TRACEMESH_STAGING_DIR \"${PROJECT_BINARY_DIR}/packaging\")")
install(SCRIPT ${CMAKE_CURRENT_LIST_DIR}/install_service.cmake)
