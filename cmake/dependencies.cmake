# Every dependency comes from a Debian 12 package (scripts/install-deps.sh installs them).
find_package(Threads REQUIRED)
find_package(TBB CONFIG REQUIRED)
find_package(ZLIB REQUIRED)
find_package(Boost 1.74 CONFIG REQUIRED)
find_package(nlohmann_json CONFIG REQUIRED)
find_package(draco CONFIG REQUIRED)
find_package(TinyGLTF CONFIG REQUIRED)  # Debian libtinygltf-dev: the glTF writer of proto/ (and the GLB reader of the tests)
find_package(spdlog CONFIG REQUIRED)
find_package(CLI11 CONFIG REQUIRED)
find_package(OpenSSL REQUIRED)
# node bundles the web viewer that tracemeshd embeds (web/build.mjs, esbuild) and runs the npm checkers of the
# suite (glTF validator, OpenAPI lint, JSON-schema checks, the browser test): package.json.
find_program(NODE_EXECUTABLE node REQUIRED)
# Brotli (Debian libbrotli-dev 1.0.9) ships pkg-config files but no CMake package: wrap its encoder and decoder in
# imported targets brotli::enc (the service's br response coding) and brotli::dec (the tests' round trips).
find_package(PkgConfig REQUIRED)
pkg_check_modules(BROTLIENC REQUIRED IMPORTED_TARGET libbrotlienc)
pkg_check_modules(BROTLIDEC REQUIRED IMPORTED_TARGET libbrotlidec)
add_library(brotli::enc INTERFACE IMPORTED)
set_target_properties(brotli::enc PROPERTIES INTERFACE_LINK_LIBRARIES PkgConfig::BROTLIENC)
add_library(brotli::dec INTERFACE IMPORTED)
set_target_properties(brotli::dec PROPERTIES INTERFACE_LINK_LIBRARIES PkgConfig::BROTLIDEC)
# hiredis (Debian libhiredis-dev 0.14) ships a .pc file but no CMake package: the Redis client of server/redis/.
pkg_check_modules(HIREDIS REQUIRED IMPORTED_TARGET hiredis)
add_library(hiredis::hiredis INTERFACE IMPORTED)
set_target_properties(hiredis::hiredis PROPERTIES INTERFACE_LINK_LIBRARIES PkgConfig::HIREDIS)
# gemmi (Debian gemmi-dev 0.5.7) is header-only and ships neither a CMake package nor a .pc file: find its
# header and wrap it in an imported target. Its CIF parser includes PEGTL, which Debian ships separately
# (tao-pegtl-dev, CMake package `pegtl`, target taocpp::pegtl); its gzip helpers use zlib.
find_package(pegtl CONFIG REQUIRED)
find_path(GEMMI_INCLUDE_DIR gemmi/mmread.hpp REQUIRED)
add_library(gemmi::headers INTERFACE IMPORTED)
set_target_properties(gemmi::headers PROPERTIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "${GEMMI_INCLUDE_DIR}"
                      INTERFACE_INCLUDE_DIRECTORIES "${GEMMI_INCLUDE_DIR}"
                      INTERFACE_LINK_LIBRARIES "taocpp::pegtl;ZLIB::ZLIB")
if(TRACEMESH_BUILD_TESTS)
  find_package(GTest CONFIG REQUIRED)
  find_package(CGAL CONFIG QUIET)
  find_program(DRACO_DECODER draco_decoder)
  find_program(CURL_EXECUTABLE curl)
  find_program(REDIS_SERVER_EXECUTABLE redis-server)  # tests/support/redis_process.hpp starts its own
endif()
if(TRACEMESH_BUILD_BENCH)
  find_package(benchmark CONFIG REQUIRED)
endif()
