#pragma once
/// @file mesh_format.hpp
/// The mesh wire formats the service and the CLI emit, with their names, media types and file extensions.

#include <string_view>

#include "core/status.hpp"

namespace tracemesh::proto {

/// Output encodings of a surface mesh (see mesh_encoders.hpp for the exact byte layout of each).
enum class mesh_format {
  off,    ///< ASCII Object File Format: human-readable, lossless to 9 significant digits
  draco,  ///< Google Draco 1.5.5 bitstream: compact, positions quantised to ≤ 0.01 Å
};

/// "off" → off, "draco" → draco (case-sensitive: these are the API's spellings).
/// @return errc::invalid_argument naming the accepted values for anything else.
result<mesh_format> parse_mesh_format(std::string_view name);

/// The API spelling of `format`: "off" | "draco" (parse_mesh_format's inverse).
std::string_view format_name(mesh_format format) noexcept;

/// Media type served with the mesh bytes.
/// off → "model/vnd.off" (no IANA registration exists; this is the de-facto name used by e.g. three.js tooling);
/// draco → "application/vnd.google.draco" (the name Draco's own web examples and glTF tooling use).
std::string_view content_type(mesh_format format) noexcept;

/// File name extension including the dot: ".off" | ".drc".
std::string_view file_extension(mesh_format format) noexcept;

}  // namespace tracemesh::proto
