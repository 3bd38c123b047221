# What the Python package (python/) is built with: Debian's python3 with its numpy (python3-numpy, python3-dev) and
# pybind11 (pybind11-dev). Sets TRACEMESH_PYTHON_FOUND, which TRACEMESH_BUILD_PYTHON=AUTO follows.
#
# Debian's interpreter is preferred over a python3 earlier on PATH (pyenv, conda): Debian's numpy and pybind11 are
# installed for it alone, and the module must be built for the interpreter that imports it.
if(NOT DEFINED Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python3_EXECUTABLE /usr/bin/python3)
endif()
find_package(Python3 3.9 COMPONENTS Interpreter Development.Module NumPy QUIET)
if(Python3_FOUND)
  set(PYBIND11_FINDPYTHON ON)  # pybind11 uses the Python3 found above rather than searching again
  find_package(pybind11 2.6 CONFIG QUIET)
endif()
if(Python3_FOUND AND pybind11_FOUND)
  set(TRACEMESH_PYTHON_FOUND ON)
else()
  set(TRACEMESH_PYTHON_FOUND OFF)
endif()
