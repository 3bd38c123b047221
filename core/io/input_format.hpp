#pragma once
/// @file input_format.hpp
/// Which reader a molecule file needs: the format a request or a file name declares, checked against the content,
/// or, when nothing is declared, the format detected from the content; and the options of the readers that assign
/// radii themselves (PDB, mmCIF).
///
/// Detection rule, applied to the text after gzip decompression, line by line from the top:
/// 1. The first line that is neither blank nor a '#' comment starts with "data_": mmCIF.
/// 2. The first non-blank line is exactly four numbers: xyzr (x y z r, as MSMS and NanoShaper read).
/// 3. A HEADER or CRYST1 record before the first atom record: PDB (deposited PDB files start so; PQR writers
///    do not write them).
/// 4. Atom records (ATOM/HETATM, as the PQR reader defines them): every one is looked at, and the file is PQR when
///    at least half of them end with five numbers (x y z charge radius), else PDB (whose records end with an
///    element symbol, "... 1.00 37.73           N", or are too short). A majority decides, not the first record,
///    so that one damaged line ("*****" or "nan" for a radius, a column missing) never turns a PQR file into a PDB
///    file read with table radii: the PQR reader names the damaged lines instead.
/// 5. No atom record: xyzr when the first non-blank line has four fields and starts as a number does (a damaged
///    xyzr line such as "1.0 2.0 3.0 *****", which its reader names), else PQR (whose reader then reports that
///    there is nothing to mesh).
/// The ambiguous case is a PDB file without element symbols and without HEADER/CRYST1 (some MD tools write
/// them): its records end with occupancy and B-factor, five numbers, and it reads as PQR; a PQR record's
/// radius is then the B-factor, usually an error (> 10 Å, or 0 everywhere) — declare the format (format_in=pdb,
/// the field 'structure' with a .pdb name on the command line), add the element columns or a CRYST1 line.
///
/// A declared format (the service's format_in= parameter or its file field 'pqr', the command's file extension)
/// takes precedence over detection, but not over unmistakable content: a declaration the content contradicts is
/// an error (check_declared_format), never a misread.

#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "core/io/vdw_radii.hpp"
#include "core/status.hpp"

namespace tracemesh {

enum class input_format { pqr, pdb, mmcif, xyzr };

/// "pqr", "pdb", "mmcif", "xyzr".
std::string_view input_format_name(input_format format) noexcept;

/// Reads a name input_format_name writes. Error: errc::invalid_argument naming the accepted values.
result<input_format> parse_input_format(std::string_view name);

/// The format a file name declares by its extension, case-insensitive, optionally followed by ".gz": .pqr → pqr,
/// .pdb and .ent → pdb, .cif and .mmcif → mmcif, .xyzr → xyzr; nullopt for any other name (detected then).
std::optional<input_format> input_format_of_file_name(std::string_view file_name);

/// What the detection rule saw in a text: the facts check_declared_format weighs against a declaration.
struct format_evidence {
  bool mmcif_header = false;       ///< rule 1: the first meaningful line starts with "data_"
  bool xyzr_first_line = false;    ///< rule 2: the first non-blank line is four numbers
  bool xyzr_like_first = false;    ///< the first non-blank line has four fields and starts as a number does
  bool pdb_header = false;         ///< rule 3: HEADER or CRYST1 before the first atom record
  std::size_t atom_records = 0;    ///< ATOM/HETATM records, whatever they end with
  /// Of those, the ones ending with five numbers and the others (PDB records, damaged PQR records); both stay 0
  /// when the records were only counted (record_evidence::counted).
  std::size_t pqr_records = 0;
  std::size_t other_records = 0;
};

/// What examine_input_format learns from an atom record: whether it ends with five numbers (rule 4, which
/// detected_format needs), or only that it is one (all check_declared_format needs: the reader chosen by a
/// declaration parses every record itself, so classifying them first would parse them twice).
enum class record_evidence { classified, counted };

/// The evidence in `text` (already decompressed, a byte order mark allowed), each line looked at up to
/// max_line_bytes. Stops at the decisive line of rules 1–3, else reads every line; linear in text.size().
format_evidence examine_input_format(std::string_view text, std::size_t max_line_bytes,
                                     record_evidence records = record_evidence::classified);

/// The format the evidence decides by the rule above. Precondition: the records were classified.
input_format detected_format(const format_evidence& evidence) noexcept;

/// The format of `text` by the rule above (detected_format of examine_input_format). Never fails (a malformed
/// file is reported by the reader chosen).
input_format detect_input_format(std::string_view text, std::size_t max_line_bytes);

/// A format declared for an input, and who declared it, as an error message names it ("format_in=pdb", "the
/// file field 'pqr'", "the file name 'x.pdb'").
struct declared_format {
  input_format format = input_format::pqr;
  std::string declared_by;
};

/// Whether the content can be read as declared. The content contradicts a declaration when it is unmistakably
/// another format: an mmCIF data block for any other format, or no data block for mmCIF; ATOM/HETATM records for
/// xyzr, or xyzr lines without any atom record for PQR or PDB. Between PQR and PDB the declaration decides: PDB
/// records declared PQR are refused by the PQR reader, which names them (a PDB record ends with an element
/// symbol, not a radius), and PQR-like records declared PDB are how the ambiguous case above is resolved. Error:
/// errc::invalid_input saying what the declaration and the content each say.
status check_declared_format(const declared_format& declared, const format_evidence& evidence);

/// The assembly an input is meshed as unless another is asked for: the file's own coordinates (a crystal's
/// asymmetric unit, a cryo-EM model as deposited), no symmetry operator applied.
inline constexpr std::string_view deposited_assembly = "asu";
/// The longest assembly id accepted; ids are letters, digits, '_', '-' and '.' (PDB and mmCIF ids are short:
/// "1", "2", "PAU").
inline constexpr std::size_t max_assembly_id_chars = 32;

/// How an input is read: its declared format (none: detected), and what the PDB and mmCIF readers keep and how
/// they size atoms. PQR and xyzr files carry their own radii and atoms, so the other options do not change them;
/// they have no symmetry operators either, so their assembly is deposited_assembly.
struct structure_options {
  std::optional<declared_format> format;  ///< format_in=, a file field or a file extension; nullopt: detected
  radii_set radii = radii_set::bondi;  ///< van der Waals radii by element (vdw_radii.hpp)
  bool keep_hydrogens = true;          ///< H and D atoms as the file has them (X-ray files usually have none)
  bool keep_waters = false;            ///< water molecules (HOH, WAT, DOD, ...); dropped as pdb2pqr --drop-water
  bool keep_ligands = true;            ///< HETATM groups other than water: ligands, ions, cofactors
  /// deposited_assembly, or the id of a biological assembly the file lists (PDB REMARK 350 BIOMOLECULE, mmCIF
  /// _pdbx_struct_assembly.id), built by applying its symmetry operators (pdb_mmcif_reader.hpp).
  std::string assembly = std::string(deposited_assembly);
};

/// `options` with the format its file name declares (.pqr, .pdb, .ent, .cif, .mmcif, .xyzr, each also .gz), unless
/// a format is declared already; a name without one of them leaves the format to detection.
structure_options declared_by_file_name(std::string_view file_name, structure_options options);

/// The names of the options, as service fields and query parameters (the CLI's are --radii, --hydrogens, ...).
inline constexpr std::array<std::string_view, 6> structure_option_names = {"format_in", "radii",  "hydrogens",
                                                                           "waters",    "ligands", "assembly"};

/// Reads the options by name: format_in = pqr | pdb | mmcif | xyzr (declared_by "format_in=<name>"), radii = bondi
/// | mantina, hydrogens / waters / ligands = keep | drop, assembly = asu | an id (1 to max_assembly_id_chars
/// letters, digits, '_', '-', '.'; whether the file has it is the reader's to say); an absent option keeps its
/// default. Error: errc::invalid_argument naming the option and the accepted values.
result<structure_options> parse_structure_options(
    const std::function<std::optional<std::string>(std::string_view name)>& lookup);

/// Where the radii of an input in `format` come from, as the report states it: "file" for PQR and xyzr (each atom
/// line carries its radius), else the name of the table (radii_set_name of options.radii).
std::string_view radii_source(input_format format, const structure_options& options) noexcept;

}  // namespace tracemesh
