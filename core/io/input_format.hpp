#pragma once
/// @file input_format.hpp
/// Which reader a molecule file needs, decided from its content (never from its name), and the options of the
/// readers that assign radii themselves (PDB, mmCIF).
///
/// Detection rule, applied to the text after gzip decompression, line by line from the top:
/// 1. The first line that is neither blank nor a '#' comment starts with "data_": mmCIF.
/// 2. The first non-blank line is exactly four numbers: xyzr (x y z r, as MSMS and NanoShaper read).
/// 3. A HEADER or CRYST1 record before the first atom record: PDB (deposited PDB files start so; PQR writers
///    do not write them).
/// 4. The first atom record (ATOM/HETATM, as the PQR reader defines it) ends with five numbers: PQR (x y z
///    charge radius). Any other first atom record — a PDB record ending with its element symbol ("... 1.00
///    37.73           N"), or too short — is PDB.
/// 5. No atom record at all: PQR (whose reader then reports that there is nothing to mesh).
/// The ambiguous case is a PDB file without element symbols and without HEADER/CRYST1 (some MD tools write
/// them): its records end with occupancy and B-factor, five numbers, and it reads as PQR; a PQR record's
/// radius is then the B-factor, usually an error (> 10 Å, or 0 everywhere) — add the element columns or a
/// CRYST1 line, or convert it to PQR.

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

/// The format of `text` (already decompressed) by the rule above. Looks at most at the lines up to the first
/// atom record (or the decisive line), each at most max_line_bytes long; never fails (a malformed file is
/// reported by the reader chosen).
input_format detect_input_format(std::string_view text, std::size_t max_line_bytes);

/// What the PDB and mmCIF readers keep and how they size atoms. PQR and xyzr files carry their own radii and
/// atoms, so these options do not change them.
struct structure_options {
  radii_set radii = radii_set::bondi;  ///< van der Waals radii by element (vdw_radii.hpp)
  bool keep_hydrogens = true;          ///< H and D atoms as the file has them (X-ray files usually have none)
  bool keep_waters = false;            ///< water molecules (HOH, WAT, DOD, ...); dropped as pdb2pqr --drop-water
  bool keep_ligands = true;            ///< HETATM groups other than water: ligands, ions, cofactors
};

/// The names of the options, as service fields and query parameters (the CLI's are --radii, --hydrogens, ...).
inline constexpr std::array<std::string_view, 4> structure_option_names = {"radii", "hydrogens", "waters",
                                                                           "ligands"};

/// Reads the options by name: radii = bondi | mantina, hydrogens / waters / ligands = keep | drop; an absent
/// option keeps its default. Error: errc::invalid_argument naming the option and the accepted values.
result<structure_options> parse_structure_options(
    const std::function<std::optional<std::string>(std::string_view name)>& lookup);

}  // namespace tracemesh
