#include "core/io/structure/molecule_reader.hpp"

#include <string>

#include "core/io/pqr_gzip.hpp"
#include "core/io/pqr_reader.hpp"
#include "core/io/pqr_text.hpp"
#include "core/io/structure/pdb_mmcif_reader.hpp"
#include "core/io/xyzr_reader.hpp"

namespace tracemesh {

namespace {

/// A UTF-8 byte order mark some editors put first.
constexpr std::string_view utf8_bom = "\xEF\xBB\xBF";

/// PQR and xyzr files are atoms only: no symmetry operators to build an assembly from.
status check_assembly_possible(input_format format, const structure_options& options) {
  if (options.assembly == deposited_assembly || format == input_format::pdb || format == input_format::mmcif) {
    return status::success();
  }
  return {errc::invalid_input,
          "assembly '" + detail::quote_bytes(options.assembly, max_assembly_id_chars) + "': " +
              (format == input_format::pqr ? "a PQR" : "an xyzr") +
              " file has no symmetry operators (PDB REMARK 350 BIOMT and mmCIF _pdbx_struct_oper_list have); only " +
              std::string(deposited_assembly) + " (the file's atoms) can be meshed"};
}

result<structure_read> as_structure(result<molecule> mol) {
  if (!mol) return mol.error();
  return structure_read{std::move(*mol), 0, 0};
}

result<read_molecule_result> parse_text(std::string_view text, const structure_options& options,
                                        const mesh_limits& limits) {
  // Dropped here, for every reader: the PDB reader took it for part of the first record, whose atom was lost
  // without a word, and the mmCIF reader refused "data_" behind it.
  if (text.starts_with(utf8_bom)) text.remove_prefix(utf8_bom.size());
  const format_evidence evidence = examine_input_format(
      text, limits.max_line_bytes, options.format ? record_evidence::counted : record_evidence::classified);
  if (options.format) {
    if (status readable = check_declared_format(*options.format, evidence); !readable) return readable;
  }
  const input_format format = options.format ? options.format->format : detected_format(evidence);
  if (status possible = check_assembly_possible(format, options); !possible) return possible;
  result<structure_read> read = [&]() -> result<structure_read> {
    switch (format) {
      case input_format::pqr: return as_structure(parse_pqr(text, limits));
      case input_format::xyzr: return as_structure(parse_xyzr(text, limits));
      case input_format::pdb: return read_pdb_structure(text, options, limits);
      case input_format::mmcif: return read_mmcif_structure(text, options, limits);
    }
    return as_structure(parse_pqr(text, limits));
  }();
  if (!read) return read.error();
  return read_molecule_result{std::move(read->mol), format, radii_source(format, options), options.assembly,
                              read->assembly_operators, read->assembly_merged_atoms};
}

}  // namespace

result<read_molecule_result> read_molecule(std::string_view bytes, const structure_options& options,
                                           const mesh_limits& limits, std::size_t max_text_bytes) {
  if (!detail::has_gzip_magic(bytes)) return parse_text(bytes, options, limits);  // plain text: no copy
  result<std::string> text = detail::gunzip(bytes, max_text_bytes);
  if (!text) return text.error();
  return parse_text(*text, options, limits);
}

result<read_molecule_result> read_molecule_file(const std::filesystem::path& path, const structure_options& options,
                                                const mesh_limits& limits) {
  const std::size_t max_bytes = max_pqr_text_bytes(limits);
  result<std::string> bytes = detail::read_file_bounded(path, max_bytes);
  if (!bytes) return bytes.error();
  if (!detail::has_gzip_magic(*bytes)) return parse_text(*bytes, options, limits);
  result<std::string> text = detail::gunzip(*bytes, max_bytes);
  if (!text) return text.error();
  bytes = std::string();  // release the compressed bytes before parsing
  return parse_text(*text, options, limits);
}

}  // namespace tracemesh
