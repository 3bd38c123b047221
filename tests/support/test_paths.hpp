#pragma once
// The one helper through which tests find their fixtures.
#include <filesystem>
#include <string>

namespace tracemesh::testing {

/// A molecule of the shared ladder, e.g. molecule_path("fas2.pqr").
inline std::filesystem::path molecule_path(const std::string& name) {
  return std::filesystem::path(TRACEMESH_MOLECULES_DIR) / name;
}
/// A file under tests/data/.
inline std::filesystem::path test_data_path(const std::string& name) {
  return std::filesystem::path(TRACEMESH_TEST_DATA_DIR) / name;
}
/// A binary built by this project (tracemesh, tracemeshd).
inline std::filesystem::path binary_path(const std::string& name) {
  return std::filesystem::path(TRACEMESH_BIN_DIR) / name;
}

}  // namespace tracemesh::testing
