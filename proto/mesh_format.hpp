#pragma once
/// @file mesh_format.hpp
/// The mesh wire formats the service and the CLI emit: ONE table, one row per format (API name, file extension,
/// media type, encoder, whether it is worth compressing on the wire). Everything that lists, parses, names or
/// encodes formats reads this table; adding a format is adding a row (and its encoder in mesh_encoders.hpp).

#include <span>
#include <string>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh::proto {

/// Output encodings of a surface mesh (see mesh_encoders.hpp for the exact byte layout of each).
enum class mesh_format {
  off,      ///< ASCII Object File Format: human-readable, 1e-6 Å resolution
  draco,    ///< Google Draco 1.5.5 bitstream: compact, positions quantised (step ≤ 0.01 Å)
  glb,      ///< glTF 2.0 binary, mesh compressed with KHR_draco_mesh_compression (the Draco bitstream of `draco`)
  glb_raw,  ///< glTF 2.0 binary, uncompressed float32 attributes and uint32 indices
  ply,      ///< binary little-endian PLY: float32 positions and normals, atom index and component per vertex
};

class encoder_input;

/// How a format carries vertex positions, which decides what the report states about the delivered bytes.
enum class position_encoding {
  decimal,      ///< decimal text at 1e-6 Å resolution (OFF)
  draco_grid,   ///< Draco's quantisation grid: the report gives the grid and the decoded mesh's check
  float32,      ///< IEEE float32: the report gives the check of the float32-rounded mesh
};

/// One row of the format table.
struct mesh_format_info {
  mesh_format format;
  std::string_view name;          ///< the API's spelling (`format=` parameter, CLI --format)
  std::string_view extension;     ///< file name extension including the dot
  std::string_view content_type;  ///< media type served with the bytes
  /// The encoder: a pure function of the mesh (same mesh, same bytes). Errors are the encoder's (see
  /// mesh_encoders.hpp); limit_exceeded means this format cannot carry this mesh faithfully (other formats may).
  result<std::string> (*encode)(const encoder_input& input);
  /// Worth gzip/br on the wire: text and raw binary are; Draco payloads are already entropy-coded.
  bool compressible;
  position_encoding positions;
};

/// Every format, in the order the API documents them (`off` first: it is the default).
std::span<const mesh_format_info> mesh_formats() noexcept;

/// The row of `format`.
const mesh_format_info& format_info(mesh_format format) noexcept;

/// The format whose API name is `name` (case-sensitive).
/// @return errc::invalid_argument naming the accepted values for anything else.
result<mesh_format> parse_mesh_format(std::string_view name);

/// The first format whose extension is `extension` (".glb" gives glb, the compressed one).
/// @return errc::invalid_argument when no format has it.
result<mesh_format> format_for_extension(std::string_view extension);

/// Shorthands for format_info(format).name / .content_type / .extension.
std::string_view format_name(mesh_format format) noexcept;
std::string_view content_type(mesh_format format) noexcept;
std::string_view file_extension(mesh_format format) noexcept;

/// "off, draco, glb, glb-raw or ply": the accepted names, for messages and help texts.
std::string format_names_text();

}  // namespace tracemesh::proto
