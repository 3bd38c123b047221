# The packaging of the two programs (tests/package/): the licences of what they link, --version, the man pages
# against --help, `cmake --install` into a temporary prefix and its systemd unit, CITATION.cff's version.
# install_test.sh (the .deb installed and used in a clean Debian root) is `make test-package`: it needs root,
# debootstrap and a Debian mirror.
if(TARGET tracemesh AND TARGET tracemeshd)
  set(_tm_package_tests ${CMAKE_CURRENT_SOURCE_DIR}/package)
  # A real GPL-only case the check must flag besides the system's readline users: CGAL's GPL-3+ headers compiled
  # into the CGAL test executable.
  set(_tm_gpl_linked)
  if(TARGET cgal_tests)
    set(_tm_gpl_linked --gpl-linked $<TARGET_FILE:cgal_tests> libcgal-dev)
  endif()
  add_test(NAME package.licences
           COMMAND bash ${_tm_package_tests}/licences_test.sh ${PROJECT_SOURCE_DIR}/scripts/check-licences.sh
                   --programs $<TARGET_FILE:tracemesh> $<TARGET_FILE:tracemeshd> ${_tm_gpl_linked})
  set_tests_properties(package.licences PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 300)
  add_test(NAME package.version
           COMMAND bash ${_tm_package_tests}/version_test.sh ${PROJECT_SOURCE_DIR} ${PROJECT_VERSION}
                   $<TARGET_FILE:tracemesh> $<TARGET_FILE:tracemeshd>)
  set_tests_properties(package.version PROPERTIES SKIP_RETURN_CODE 77)
  add_test(NAME package.man_pages
           COMMAND bash ${_tm_package_tests}/man_pages_test.sh
                   $<TARGET_FILE:tracemesh> ${PROJECT_SOURCE_DIR}/packaging/man/tracemesh.1
                   $<TARGET_FILE:tracemeshd> ${PROJECT_SOURCE_DIR}/packaging/man/tracemeshd.8)
  add_test(NAME package.install_tree
           COMMAND bash ${_tm_package_tests}/install_tree_test.sh ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR}
                   ${CMAKE_CURRENT_BINARY_DIR}/package_install)
  set_tests_properties(package.install_tree PROPERTIES FIXTURES_SETUP package_install TIMEOUT 120)
  add_test(NAME package.systemd_unit
           COMMAND bash ${_tm_package_tests}/systemd_unit_test.sh ${CMAKE_CURRENT_BINARY_DIR}/package_install)
  set_tests_properties(package.systemd_unit PROPERTIES FIXTURES_REQUIRED package_install SKIP_RETURN_CODE 77)
endif()
add_test(NAME package.citation
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/package/citation_test.sh ${PROJECT_SOURCE_DIR}/CITATION.cff
                 ${PROJECT_VERSION})
