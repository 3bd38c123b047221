#include "proto/mesh_format.hpp"

#include <string>

#include "proto/detail/quote.hpp"

namespace tracemesh::proto {

result<mesh_format> parse_mesh_format(std::string_view name) {
  if (name == "off") return mesh_format::off;
  if (name == "draco") return mesh_format::draco;
  return status(errc::invalid_argument,
                "format: expected \"off\" or \"draco\", got " + detail::quoted(name));
}

std::string_view format_name(mesh_format format) noexcept {
  switch (format) {
    case mesh_format::off: return "off";
    case mesh_format::draco: return "draco";
  }
  return "off";
}

std::string_view content_type(mesh_format format) noexcept {
  switch (format) {
    case mesh_format::off: return "model/vnd.off";
    case mesh_format::draco: return "application/vnd.google.draco";
  }
  return "application/octet-stream";
}

std::string_view file_extension(mesh_format format) noexcept {
  switch (format) {
    case mesh_format::off: return ".off";
    case mesh_format::draco: return ".drc";
  }
  return "";
}

}  // namespace tracemesh::proto
