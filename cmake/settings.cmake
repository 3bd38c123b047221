# tracemesh_settings: the one place for warnings and sanitizer flags; every target links it.
add_library(tracemesh_settings INTERFACE)
target_compile_options(tracemesh_settings INTERFACE -Wall -Wextra -Wpedantic)
if(TRACEMESH_WERROR)
  target_compile_options(tracemesh_settings INTERFACE -Werror)
endif()
if(TRACEMESH_SANITIZE)
  string(REPLACE ";" "," _tm_sanitizers "${TRACEMESH_SANITIZE}")
  target_compile_options(tracemesh_settings INTERFACE
    -fsanitize=${_tm_sanitizers} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  target_link_options(tracemesh_settings INTERFACE -fsanitize=${_tm_sanitizers})
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # g++ 12 + sanitizers: false maybe-uninitialized inside Beast's basic_parser.
    target_compile_options(tracemesh_settings INTERFACE -Wno-maybe-uninitialized)
  endif()
endif()
if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  set(CMAKE_BUILD_TYPE Release CACHE STRING "Build type" FORCE)
endif()
# "CI" build type: optimised but keeps assertions.
set(CMAKE_CXX_FLAGS_CI "-O2 -g" CACHE STRING "Flags for the CI build type")
