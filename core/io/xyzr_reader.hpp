#pragma once
/// @file xyzr_reader.hpp
/// Reads .xyzr files (the sphere lists MSMS and NanoShaper read): one atom per line, "x y z r" in Å.
///
/// The format accepted, precisely: text as the PQR reader accepts it (UTF-8, LF/CRLF/CR, no control bytes,
/// lines up to limits.max_line_bytes); blank lines are skipped; every other line is exactly four
/// whitespace-separated decimal numbers x y z r (numbers as the PQR reader reads them). Atoms have charge 0.
/// MSMS's .xyzrn extension (a fifth and sixth field) is not accepted: four fields, or an error naming the line.

#include <string_view>

#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// Parses xyzr text into atoms in file order.
/// Errors, each "line N: ..." quoting at most 40 bytes of the input:
/// - errc::invalid_input: a line with other than 4 fields, a field that is not a finite decimal number,
///   |coordinate| > limits.max_abs_coordinate, a negative (also -0.0) or > limits.max_radius radius, binary data.
/// - errc::limit_exceeded: more than limits.max_atoms atoms.
/// - errc::nothing_to_mesh: no atom, or every radius is 0.
result<molecule> parse_xyzr(std::string_view text, const mesh_limits& limits = {});

}  // namespace tracemesh
