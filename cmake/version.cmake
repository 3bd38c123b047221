# tracemesh_build_info: the version line of `tracemesh --version` and `tracemeshd --version` (project version,
# engine version, git commit). The header is configured once; the commit's source file is rewritten by every build
# when HEAD moved, so the binaries never print a stale commit and a new commit recompiles one small file.
# A tree without .git (a source tarball, a container build context) can name its commit: -DTRACEMESH_GIT_COMMIT=abc1234.
set(TRACEMESH_GIT_COMMIT "" CACHE STRING "Commit for --version when the source tree is no git checkout (default: git)")
if(NOT TRACEMESH_GIT_COMMIT MATCHES "^[0-9A-Za-z._+-]*$")
  message(FATAL_ERROR "TRACEMESH_GIT_COMMIT='${TRACEMESH_GIT_COMMIT}': letters, digits and . _ + - only")
endif()
set(_tm_generated ${PROJECT_BINARY_DIR}/generated/build_info)
configure_file(${CMAKE_CURRENT_LIST_DIR}/build_info.hpp.in ${_tm_generated}/tracemesh_build_info.hpp @ONLY)
add_custom_target(tracemesh_build_commit
  COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${PROJECT_SOURCE_DIR} -DGIT_COMMIT=${TRACEMESH_GIT_COMMIT}
          -DTEMPLATE=${CMAKE_CURRENT_LIST_DIR}/build_commit.cpp.in -DOUTPUT=${_tm_generated}/build_commit.cpp
          -P ${CMAKE_CURRENT_LIST_DIR}/write_build_commit.cmake
  BYPRODUCTS ${_tm_generated}/build_commit.cpp
  COMMENT "Reading the git commit for --version"
  VERBATIM)
add_library(tracemesh_build_info STATIC ${_tm_generated}/build_commit.cpp)
add_dependencies(tracemesh_build_info tracemesh_build_commit)
target_include_directories(tracemesh_build_info PUBLIC ${_tm_generated} ${PROJECT_SOURCE_DIR})
target_link_libraries(tracemesh_build_info PRIVATE tracemesh_settings)
