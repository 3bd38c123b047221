// Fuzz target of the PDB reader (gemmi behind pdb_mmcif_reader.hpp): bytes → atoms or a status, never a crash
// or an exception (reader_invariants.hpp); every option combination is tried on each input.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/io/structure/pdb_mmcif_reader.hpp"
#include "reader_invariants.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const tracemesh::mesh_limits limits = tracemesh::fuzz::small_limits();
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  for (int variant = 0; variant < 4; ++variant) {
    tracemesh::structure_options options;
    options.radii = variant % 2 == 0 ? tracemesh::radii_set::bondi : tracemesh::radii_set::mantina;
    options.keep_waters = variant >= 2;
    options.keep_ligands = variant < 2;
    options.keep_hydrogens = variant != 1;
    tracemesh::fuzz::check("pdb_reader_fuzzer", tracemesh::parse_pdb(text, options, limits), limits);
  }
  return 0;
}
