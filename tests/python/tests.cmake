# The Python package's tests (tests/python/test_*.py, Debian's python3-pytest): the package of the build tree through
# PYTHONPATH, the built tracemesh and tracemeshd, and the suite's molecules, named by environment variables
# (conftest.py). One ctest per file: python.test_local, python.test_client.
# Sanitizer builds do not build the package (CMakeLists.txt says why), so they have no Python tests.
if(TARGET tracemesh_python)
  file(GLOB _python_test_files CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/python/test_*.py)
  foreach(_file IN LISTS _python_test_files)
    get_filename_component(_name ${_file} NAME_WE)
    add_test(NAME python.${_name}
             COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${TRACEMESH_PYTHON_DIR} PYTHONDONTWRITEBYTECODE=1
                     TRACEMESH_CLI=$<TARGET_FILE:tracemesh> TRACEMESHD=$<TARGET_FILE:tracemeshd>
                     TRACEMESH_TEST_MOLECULES=${TRACEMESH_MOLECULES_DIR}
                     ${Python3_EXECUTABLE} -m pytest -p no:cacheprovider -q ${_file})
    set_tests_properties(python.${_name} PROPERTIES TIMEOUT 900)
  endforeach()
endif()
