#include "cli/nanoshaper/nanoshaper_files.hpp"

#include <array>
#include <charconv>
#include <cstdint>
#include <string_view>

#include "proto/mesh_encoders.hpp"

namespace tracemesh::cli::nanoshaper {
namespace {

constexpr int decimals = 6;  // as proto's MSMS writer: 1e-6 Å

/// `msms` (an MSMS file of proto's encoders) with its three header lines replaced by NanoShaper's.
std::string with_nanoshaper_header(const std::string& msms, std::string_view what, std::size_t count) {
  std::size_t body = 0;
  for (int line = 0; line < 3; ++line) body = msms.find('\n', body) + 1;
  std::string out = "# File created by tracemesh (NanoShaper-compatible)\n#";
  out += what;
  out += '\n';
  out += std::to_string(count);
  out += '\n';
  out.append(msms, body, std::string::npos);
  return out;
}

void append_number(std::string& out, double value) {
  std::array<char, 64> buffer{};
  const auto written = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value, std::chars_format::fixed,
                                     decimals);
  out.append(buffer.data(), written.ptr);
}

void append_integer(std::string& out, std::uint64_t value) {
  std::array<char, 24> buffer{};
  const auto written = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), written.ptr);
}

}  // namespace

std::string nanoshaper_vert(const surface_mesh& mesh) {
  return with_nanoshaper_header(proto::encode_msms_vert(mesh), "vertex", mesh.vertex_count());
}

std::string nanoshaper_face(const surface_mesh& mesh) {
  return with_nanoshaper_header(proto::encode_msms_face(mesh), "faces", mesh.triangle_count());
}

std::string nanoshaper_off(const surface_mesh& mesh, bool normals, bool atoms) {
  std::string out = normals && atoms ? "OFF+N+A\n" : normals ? "OFF+N\n" : atoms ? "OFF+A\n" : "OFF\n";
  append_integer(out, mesh.vertex_count());
  out += ' ';
  append_integer(out, mesh.triangle_count());
  out += " 0\n";
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const vec3& p = mesh.positions[i];
    const vec3 normal = i < mesh.normals.size() ? mesh.normals[i] : vec3{};
    std::array<double, 6> values = {p.x, p.y, p.z, normal.x, normal.y, normal.z};
    for (std::size_t k = 0; k < (normals ? 6U : 3U); ++k) {
      if (k > 0) out += ' ';
      append_number(out, values[k]);
    }
    if (atoms) {
      out += ' ';
      append_integer(out, i < mesh.atom_index.size() ? mesh.atom_index[i] : 0U);
    }
    out += '\n';
  }
  for (const auto& t : mesh.triangles) {
    out += "3";
    for (const std::uint32_t vertex : t) {
      out += ' ';
      append_integer(out, vertex);
    }
    out += '\n';
  }
  return out;
}

}  // namespace tracemesh::cli::nanoshaper
