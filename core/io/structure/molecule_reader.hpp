#pragma once
/// @file molecule_reader.hpp
/// One entry point for every input format: gzip is undone, the format declared in structure_options::format is
/// checked against the content, or the format is detected from it (input_format.hpp), and the matching reader
/// runs: PQR (pqr_reader.hpp), xyzr (xyzr_reader.hpp), PDB or mmCIF (pdb_mmcif_reader.hpp).

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/io/input_format.hpp"
#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

struct read_molecule_result {
  molecule mol;
  input_format format = input_format::pqr;  ///< the format read
  std::string_view radii = "file";          ///< where the radii came from (radii_source)
  std::string assembly = std::string(deposited_assembly);  ///< structure_options::assembly, built
  std::size_t assembly_operators = 0;       ///< symmetry operators applied (structure_read); 0 for deposited_assembly
  std::size_t assembly_merged_atoms = 0;    ///< copies merged on symmetry axes (structure_read)
};

/// Parses `bytes` (plain or gzip, decompressed to at most max_text_bytes). Errors: those of maybe_gunzip, of
/// check_declared_format when options.format is set, errc::invalid_input for an assembly other than
/// deposited_assembly asked of a PQR or xyzr input (no symmetry operators), and those of the reader chosen.
result<read_molecule_result> read_molecule(std::string_view bytes, const structure_options& options,
                                           const mesh_limits& limits, std::size_t max_text_bytes);

/// Reads a file of any supported format, plain or gzip, at most max_pqr_text_bytes(limits) bytes (plain or
/// decompressed). The file name is not looked at: a caller that lets the extension declare the format sets
/// options.format (input_format_of_file_name). Errors: errc::io_error naming the path, errc::limit_exceeded,
/// then as read_molecule.
result<read_molecule_result> read_molecule_file(const std::filesystem::path& path, const structure_options& options,
                                                const mesh_limits& limits = {});

}  // namespace tracemesh
