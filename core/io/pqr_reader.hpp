#pragma once
/// @file pqr_reader.hpp
/// Reads PQR files (whitespace-separated; the last five fields of ATOM/HETATM records are x y z charge radius).
///
/// The format accepted, precisely:
/// - Text is UTF-8 (ASCII in practice). One UTF-8 byte order mark at the very start is skipped. Lines end with
///   LF, CRLF or a bare CR. Any other control byte (NUL, 0x01–0x08, 0x0B, 0x0C, 0x0E–0x1F, 0x7F), a byte
///   sequence that is not UTF-8, or a UTF-16 byte order mark is an error: the input is binary, not PQR.
/// - A line is an atom record when it starts (column 1, case-sensitive) with "ATOM" or "HETATM" followed by a
///   space, a tab, a digit (PDB style "HETATM1234", "ATOM100000") or the end of the line. Every other line
///   (REMARK, TER, END, MODEL, ENDMDL, CRYST1, blank, " ATOM" with a leading space, "ATOMS"...) is skipped.
/// - Fields are separated by spaces or tabs. An atom record has exactly 10 fields (APBS/pdb2pqr without chain
///   id: `ATOM serial name resName resSeq x y z charge radius`) or 11 (a chain id before resSeq), counted after
///   fused fields are split (below); any other count is an error naming the line, never a shifted read.
/// - The last five numbers are x, y, z (Å), charge (e) and radius (Å). Of the fields before them only the one
///   just before x is checked: it must be a residue number (optional '-', digits, an optional insertion-code
///   letter; in the 10-field layout also a one-character chain id fused in front, "A1000"). This catches a
///   missing or extra column that a chain id would otherwise hide ("ATOM 1 N GLY A 1 1.0 2.0 0.5 1.5", z
///   missing: 10 fields, but 'A' stands where the residue number should be). The serial and the names are not
///   interpreted. Residual ambiguity: a record with a *numeric* chain id and one number missing reads as the
///   10-field layout; no count can tell them apart.
/// - Fused fields (PDB fixed-column output where coordinates touch, "-12.345-67.890"): within a field, a '-'
///   that directly follows a digit starts a new number, so that field reads as -12.345 and -67.890. No other
///   split is made: "1.234-5.678" splits, "1.0e-5" does not, and fused fields that the rule cannot separate
///   ("12.345678.901", "-0.4161.824") are errors, never misread.
/// - Numbers are decimal, as std::from_chars reads them (locale-independent), plus an optional leading '+'.
///   NaN, infinities, hexadecimal ("0x1p3"), decimal commas ("1,5"), trailing characters ("1.5abc") and values
///   out of double range ("1e400", "1e-400") are errors.
/// - A radius of exactly 0 is accepted (AMBER hydroxyl hydrogens) and counted in molecule::zero_radius_atoms;
///   a negative radius, including -0.0, is an error.

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// Bytes of PQR text allowed per atom of limits.max_atoms when reading a file (plain or decompressed): a PQR
/// atom line is under 100 bytes, so this leaves room for remarks while bounding memory.
inline constexpr std::size_t pqr_max_bytes_per_atom = 200;

/// Largest PQR text read_pqr_file accepts: limits.max_atoms × pqr_max_bytes_per_atom (saturating).
std::size_t max_pqr_text_bytes(const mesh_limits& limits) noexcept;

/// Parses PQR text (format above) into atoms in file order.
/// Errors, each a one-line message starting "line N: " (N 1-based) that quotes at most 40 bytes of the input,
/// with non-printable bytes escaped as \xNN:
/// - errc::invalid_input: a field count other than 10 or 11, no residue number before x, an unparsable or non-finite number, |coordinate| >
///   limits.max_abs_coordinate, a negative or > limits.max_radius radius, NUL/control/non-UTF-8 bytes, a
///   UTF-16 byte order mark, a line longer than limits.max_line_bytes (line terminator excluded). The parse goes
///   on past an unreadable atom record (fields, numbers, ranges): the message is the first one's, followed, when
///   there are more, by "; N of M atom records cannot be read as PQR (lines a, b, c, d, e, ...)" (the first five
///   line numbers). Text errors (bytes, line length) stop at once.
/// - errc::limit_exceeded: an atom record beyond limits.max_atoms; parsing stops at that line.
/// - errc::nothing_to_mesh ("no atoms with radius > 0 ..."): no atom record, or every radius is 0.
/// Linear time in text.size(); a line is never scanned past limits.max_line_bytes + 1 bytes.
result<molecule> parse_pqr(std::string_view text, const mesh_limits& limits = {});

/// Decompresses `bytes` when they start with the gzip magic (1f 8b), else returns them unchanged.
/// Concatenated gzip members are decompressed one after the other (as gzip -d does).
/// Errors: errc::invalid_input on a corrupt or truncated stream, or bytes after the last member that are not
/// another member; errc::limit_exceeded as soon as the output would exceed max_bytes (memory stays bounded).
result<std::string> maybe_gunzip(std::string_view bytes, std::size_t max_bytes);

/// Reads a .pqr or .pqr.gz file (gzip detected from the content, not the name) and parses it with parse_pqr.
/// Errors: errc::io_error naming the path when the file cannot be opened or read; errc::limit_exceeded when the
/// file or its decompressed text is larger than max_pqr_text_bytes(limits); otherwise as maybe_gunzip and
/// parse_pqr (parse messages are not prefixed with the path).
result<molecule> read_pqr_file(const std::filesystem::path& path, const mesh_limits& limits = {});

}  // namespace tracemesh
