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
# The Python package (python/), when this build tree has built it: `make build` does, `make run` (the two programs
# only) does not, and then nothing is installed for it. Its folder goes where Debian's python3 imports packages
# from: <prefix>/lib/python3/dist-packages for /usr (as Debian packages), <prefix>/lib/python3.X/dist-packages for any
# other prefix (Debian's python3 looks in /usr/local/lib/python3.X/dist-packages, not in .../python3/...).
# `cmake --install` installs every component; `cmake --install --component python` the package alone.
if(TARGET tracemesh_python)
  install(CODE "
    set(_tm_package \"${TRACEMESH_PYTHON_DIR}/tracemesh\")
    if(NOT EXISTS \"\${_tm_package}/$<TARGET_FILE_NAME:tracemesh_python>\")
      message(STATUS \"Not installing the Python package: not built (cmake --build ${PROJECT_BINARY_DIR} --target tracemesh_python)\")
    else()
      if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
        set(_tm_site lib/python3/dist-packages)
      else()
        set(_tm_site lib/python${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}/dist-packages)
      endif()
      file(INSTALL \"\${_tm_package}\" DESTINATION \"\${CMAKE_INSTALL_PREFIX}/\${_tm_site}\"
           PATTERN __pycache__ EXCLUDE)
    endif()" COMPONENT python)  # its own component: the .deb of the two programs need not carry it (nor numpy)
endif()
