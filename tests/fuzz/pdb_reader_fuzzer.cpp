// Fuzz target of the PDB reader (gemmi behind pdb_mmcif_reader.hpp): bytes → atoms or a status, never a crash
// or an exception (reader_invariants.hpp); every option combination is tried on each input.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/io/structure/pdb_mmcif_reader.hpp"
#include "reader_invariants.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  tracemesh::fuzz::check_every_structure_option("pdb_reader_fuzzer", text, [](auto... args) {
    return tracemesh::parse_pdb(args...);
  });
  return 0;
}
