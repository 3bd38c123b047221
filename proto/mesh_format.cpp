#include "proto/mesh_format.hpp"

#include <array>

#include "proto/detail/quote.hpp"
#include "proto/mesh_encoders.hpp"

namespace tracemesh::proto {
namespace {

// Media types: model/gltf-binary is registered with IANA; OFF and PLY are not ("model/vnd.off" is the de-facto
// name three.js tooling uses, "model/x-ply" the unregistered one mesh servers send); Draco's is the one its web
// examples and glTF tooling use.
constexpr std::array<mesh_format_info, 5> format_table = {{
    {mesh_format::off, "off", ".off", "model/vnd.off", encode_off, true, position_encoding::decimal},
    {mesh_format::draco, "draco", ".drc", "application/vnd.google.draco", encode_draco, false, position_encoding::draco_grid},
    {mesh_format::glb, "glb", ".glb", "model/gltf-binary", encode_glb, false, position_encoding::draco_grid},
    {mesh_format::glb_raw, "glb-raw", ".glb", "model/gltf-binary", encode_glb_raw, true, position_encoding::float32},
    {mesh_format::ply, "ply", ".ply", "model/x-ply", encode_ply, true, position_encoding::float32},
}};

}  // namespace

std::span<const mesh_format_info> mesh_formats() noexcept { return format_table; }

const mesh_format_info& format_info(mesh_format format) noexcept {
  for (const mesh_format_info& row : format_table) {
    if (row.format == format) return row;
  }
  return format_table.front();  // unreachable: every enumerator has a row (tested)
}

std::string format_names_text() {
  std::string text;
  for (std::size_t i = 0; i < format_table.size(); ++i) {
    if (i > 0) text += i + 1 == format_table.size() ? " or " : ", ";
    text += format_table[i].name;
  }
  return text;
}

result<mesh_format> parse_mesh_format(std::string_view name) {
  for (const mesh_format_info& row : format_table) {
    if (row.name == name) return row.format;
  }
  return status(errc::invalid_argument, "format: expected " + format_names_text() + ", got " + detail::quoted(name));
}

result<mesh_format> format_for_extension(std::string_view extension) {
  for (const mesh_format_info& row : format_table) {
    if (row.extension == extension) return row.format;
  }
  return status(errc::invalid_argument, "no mesh format has the extension " + detail::quoted(extension));
}

std::string_view format_name(mesh_format format) noexcept { return format_info(format).name; }
std::string_view content_type(mesh_format format) noexcept { return format_info(format).content_type; }
std::string_view file_extension(mesh_format format) noexcept { return format_info(format).extension; }

}  // namespace tracemesh::proto
