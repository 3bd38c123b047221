# tracemesh_settings: the one place for warnings and sanitizer flags; every target links it.
add_library(tracemesh_settings INTERFACE)
target_compile_options(tracemesh_settings INTERFACE -Wall -Wextra -Wpedantic)
# The libraries are position-independent (they are linked into the Python extension too, python/CMakeLists.txt);
# without interposition of their functions the compiler inlines and calls them as it does in an executable.
target_compile_options(tracemesh_settings INTERFACE -fno-semantic-interposition)
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
# "CI" build type (the sanitizer build): keeps assertions; -O1 -g1 as the AddressSanitizer documentation advises.
# Measured on server/http/http_server.cpp with -fsanitize=address,undefined: 283 s of CPU at -O2 -g, 119 s at -O1 -g1
# (Release -O3: 40 s); line tables (-g1) are all a sanitizer's stack trace needs. (CMake pre-creates an empty
# CMAKE_CXX_FLAGS_CI, hence FORCE; a build directory made with the old "-O2 -g" default is moved to the new one.)
if(NOT CMAKE_CXX_FLAGS_CI OR CMAKE_CXX_FLAGS_CI STREQUAL "-O2 -g")
  set(CMAKE_CXX_FLAGS_CI "-O1 -g1" CACHE STRING "Flags for the CI build type" FORCE)
endif()
# tracemesh_unoptimised_in_ci(targets... [NEVER_FUZZED]): compiled at -O0 in the CI build type, but in a fuzzing
# build (TRACEMESH_BUILD_FUZZERS: a campaign runs as fast as the code it fuzzes) unless NEVER_FUZZED. For the service
# (HTTP, jobs, storage), the command's driver, the encoders and the tests' own code: their tests wait on sockets,
# processes and events, not on their speed, while Beast's and Asio's templates make most of the sanitizer build's
# compile time. The mesher's libraries keep -O1: meshing is most of the sanitized suite's run time.
# Measured on 2 cores (g++ 12, -fsanitize=address,undefined): tracemesh_server's largest unity file 90 s of CPU at
# -O1 -g1, 53 s at -O0; with tracemeshd's main.cpp compiled once (server/CMakeLists.txt), the whole sanitizer build
# 7 min 55 s → 7 min 0 s and `make test-tsan` 5 min 46 s → 4 min 0 s, the service's tests no slower.
function(tracemesh_unoptimised_in_ci)
  cmake_parse_arguments(PARSE_ARGV 0 _tm "NEVER_FUZZED" "" "")
  if(TRACEMESH_BUILD_FUZZERS AND NOT _tm_NEVER_FUZZED)
    return()
  endif()
  foreach(_target IN LISTS _tm_UNPARSED_ARGUMENTS)
    target_compile_options(${_target} PRIVATE $<$<CONFIG:CI>:-O0>)
  endforeach()
endfunction()
# Fuzzer builds instrument every library for coverage, so libFuzzer sees inside the parsers.
if(TRACEMESH_BUILD_FUZZERS)
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
