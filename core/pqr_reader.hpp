#pragma once
/// @file pqr_reader.hpp
/// Reads PQR files (whitespace-separated; the last five fields of ATOM/HETATM records are x y z charge radius).

#include <filesystem>
#include <string_view>

#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// Parses PQR text. Errors (errc::invalid_input, message names the 1-based line): too few fields, unparsable or
/// non-finite numbers, |coordinate| > limits.max_abs_coordinate, negative or > limits.max_radius radius, NUL or
/// binary bytes, a line over limits.max_line_bytes. errc::limit_exceeded past limits.max_atoms (found while
/// streaming). errc::nothing_to_mesh when no ATOM/HETATM record has radius > 0. Locale-independent.
result<molecule> parse_pqr(std::string_view text, const mesh_limits& limits = {});

/// Decompresses `bytes` when they start with the gzip magic, else returns them unchanged; errc::invalid_input on
/// a corrupt stream, errc::limit_exceeded when the output would exceed max_bytes.
result<std::string> maybe_gunzip(std::string_view bytes, std::size_t max_bytes);

/// Reads a .pqr or .pqr.gz file (gzip detected from the content). errc::io_error when it cannot be read.
result<molecule> read_pqr_file(const std::filesystem::path& path, const mesh_limits& limits = {});

}  // namespace tracemesh
