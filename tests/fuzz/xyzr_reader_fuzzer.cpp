// Fuzz target of the xyzr reader: bytes → atoms or a status, never a crash (reader_invariants.hpp).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/io/xyzr_reader.hpp"
#include "reader_invariants.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const tracemesh::mesh_limits limits = tracemesh::fuzz::small_limits();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  tracemesh::fuzz::check("xyzr_reader_fuzzer", tracemesh::parse_xyzr(text, limits), limits);
  return 0;
}
