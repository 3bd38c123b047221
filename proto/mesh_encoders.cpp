#include "proto/mesh_encoders.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <memory>
#include <system_error>

#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"

namespace tracemesh::proto {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// Text helpers: std::to_chars is locale-free and exact, unlike printf/iostreams under a user locale.

void append_general(std::string& out, double value, int significant_digits) {
  char buffer[64];
  if (value == 0) value = 0;  // print -0 as 0
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::general,
                                     significant_digits);
  out.append(buffer, written.ptr);
}

void append_fixed(std::string& out, double value, int decimals) {
  char buffer[400];  // the longest fixed-notation double (≈ 1.8e308) fits
  if (value == 0) value = 0;
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed, decimals);
  if (written.ec == std::errc{}) {
    out.append(buffer, written.ptr);
  } else {
    append_general(out, value, 17);
  }
}

void append_integer(std::string& out, std::uint64_t value) {
  char buffer[24];
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, written.ptr);
}

constexpr int off_significant_digits = 9;  // 1e-6 Å resolution up to ±1000 Å
constexpr int msms_decimals = 6;

double triangle_area(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& t) {
  const std::size_t n = mesh.positions.size();
  if (t[0] >= n || t[1] >= n || t[2] >= n) return 0;
  const vec3& a = mesh.positions[t[0]];
  return 0.5 * norm(cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a));
}

/// Header line 3 shared by .vert and .face: "<count> <spheres> <density> <probe radius>".
std::string msms_counts_line(const surface_mesh& mesh, std::size_t count) {
  std::uint64_t spheres = 0;
  for (const std::uint32_t atom : mesh.atom_index) spheres = std::max<std::uint64_t>(spheres, atom + 1ULL);
  double area = 0;
  for (const auto& t : mesh.triangles) area += triangle_area(mesh, t);
  const double density = area > 0 ? static_cast<double>(mesh.vertex_count()) / area : 0.0;
  std::string line;
  append_integer(line, count);
  line += ' ';
  append_integer(line, spheres);
  line += ' ';
  append_fixed(line, density, 4);
  line += " 0.0\n";
  return line;
}

// ---------------------------------------------------------------------------------------------------------------
// Draco

/// Distance from |x| to the next float32 up: the float rounding step of values of magnitude |x|.
double float_ulp(double x) {
  const float f = static_cast<float>(std::fabs(x));
  return static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity())) - static_cast<double>(f);
}

status check_draco_input(const surface_mesh& mesh) {
  const std::size_t n = mesh.vertex_count();
  if (n == 0 || mesh.triangle_count() == 0) {
    return {errc::invalid_argument, "draco: the mesh has no triangle"};
  }
  if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) ||
      mesh.triangle_count() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    return {errc::limit_exceeded, "draco: more than 2^31 vertices or triangles"};
  }
  if (!mesh.normals.empty() && mesh.normals.size() != n) {
    return {errc::invalid_argument, "draco: normals must have one entry per vertex"};
  }
  if (!mesh.atom_index.empty() && mesh.atom_index.size() != n) {
    return {errc::invalid_argument, "draco: atom_index must have one entry per vertex"};
  }
  for (const auto& t : mesh.triangles) {
    if (t[0] >= n || t[1] >= n || t[2] >= n) {
      return {errc::invalid_argument, "draco: a triangle refers to a vertex past the end"};
    }
  }
  for (const auto& normal : mesh.normals) {
    if (!std::isfinite(normal.x) || !std::isfinite(normal.y) || !std::isfinite(normal.z)) {
      return {errc::invalid_argument, "draco: non-finite normal"};
    }
  }
  return status::success();
}

template <class T, std::size_t components>
void add_attribute(draco::Mesh& target, draco::GeometryAttribute::Type type, draco::DataType data_type,
                   const std::vector<std::array<T, components>>& values, std::uint32_t unique_id) {
  auto attribute = std::make_unique<draco::PointAttribute>();
  attribute->Init(type, static_cast<std::int8_t>(components), data_type, false, values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    attribute->SetAttributeValue(draco::AttributeValueIndex(static_cast<std::uint32_t>(i)), values[i].data());
  }
  const int id = target.AddAttribute(std::move(attribute));
  target.attribute(id)->set_unique_id(unique_id);
}

void add_atom_index_attribute(draco::Mesh& target, const std::vector<std::uint32_t>& atom_index) {
  std::vector<std::array<std::int32_t, 1>> values(atom_index.size());
  for (std::size_t i = 0; i < atom_index.size(); ++i) {
    // Atom counts are capped far below 2^31 (mesh_limits::max_atoms); the cast keeps the bits regardless.
    values[i][0] = static_cast<std::int32_t>(atom_index[i]);
  }
  add_attribute(target, draco::GeometryAttribute::GENERIC, draco::DT_INT32, values,
                draco_settings::atom_index_unique_id);
  const int id = target.num_attributes() - 1;
  auto metadata = std::make_unique<draco::AttributeMetadata>();
  metadata->AddEntryString("name", "atom_index");
  target.AddAttributeMetadata(id, std::move(metadata));
}

/// The mesh as Draco's structure, attributes mapped one value per point (no deduplication, no seams).
std::unique_ptr<draco::Mesh> to_draco_mesh(const surface_mesh& mesh) {
  auto target = std::make_unique<draco::Mesh>();
  const std::size_t n = mesh.vertex_count();
  target->set_num_points(static_cast<std::uint32_t>(n));
  target->SetNumFaces(mesh.triangle_count());
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f) {
    const auto& t = mesh.triangles[f];
    target->SetFace(draco::FaceIndex(static_cast<std::uint32_t>(f)),
                    {draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  std::vector<std::array<float, 3>> positions(n);
  std::transform(mesh.positions.begin(), mesh.positions.end(), positions.begin(), to_float3);
  add_attribute(*target, draco::GeometryAttribute::POSITION, draco::DT_FLOAT32, positions, 0);
  if (!mesh.normals.empty()) {
    std::vector<std::array<float, 3>> normals(n);
    std::transform(mesh.normals.begin(), mesh.normals.end(), normals.begin(), to_float3);
    add_attribute(*target, draco::GeometryAttribute::NORMAL, draco::DT_FLOAT32, normals, 1);
  }
  if (!mesh.atom_index.empty()) add_atom_index_attribute(*target, mesh.atom_index);
  return target;
}

}  // namespace

std::string encode_off(const surface_mesh& mesh) {
  std::string out;
  out.reserve(16 + mesh.vertex_count() * 40 + mesh.triangle_count() * 24);
  out += "OFF\n";
  append_integer(out, mesh.vertex_count());
  out += ' ';
  append_integer(out, mesh.triangle_count());
  out += " 0\n";
  for (const vec3& p : mesh.positions) {
    append_general(out, p.x, off_significant_digits);
    out += ' ';
    append_general(out, p.y, off_significant_digits);
    out += ' ';
    append_general(out, p.z, off_significant_digits);
    out += '\n';
  }
  for (const auto& t : mesh.triangles) {
    out += "3 ";
    append_integer(out, t[0]);
    out += ' ';
    append_integer(out, t[1]);
    out += ' ';
    append_integer(out, t[2]);
    out += '\n';
  }
  return out;
}

result<position_quantization> choose_position_quantization(const surface_mesh& mesh) {
  if (mesh.positions.empty()) return status(errc::invalid_argument, "draco: the mesh has no vertex");
  vec3 lo = mesh.positions.front();
  vec3 hi = lo;
  double max_magnitude = 0;
  for (const vec3& p : mesh.positions) {
    for (int axis = 0; axis < 3; ++axis) {
      if (!std::isfinite(p[axis])) return status(errc::invalid_argument, "draco: non-finite vertex coordinate");
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
      max_magnitude = std::max(max_magnitude, std::fabs(p[axis]));
    }
  }
  position_quantization grid;
  double extent = 0;
  for (int axis = 0; axis < 3; ++axis) {
    // Round the origin down so that every float32 coordinate lies at or above it.
    grid.origin[axis] = std::nextafter(static_cast<float>(lo[axis]), -std::numeric_limits<float>::infinity());
    extent = std::max(extent, hi[axis] - static_cast<double>(grid.origin[axis]));
  }
  // The margin keeps the top coordinate inside the grid despite float rounding, and the range > 0 for one point.
  grid.range = static_cast<float>(extent * (1 + 1e-6) + 1e-3);

  // Error budget per coordinate: the Euclidean bound / √3, minus float32 rounding of the input coordinate, of the
  // offset from the origin, and of the dequantised value (≈ one ulp at the magnitude plus two at the range).
  const double per_axis_budget = draco_settings::max_position_error / std::sqrt(3.0);
  const double float_error = float_ulp(max_magnitude) + 2 * float_ulp(grid.range);
  const double max_step = 2 * (per_axis_budget - float_error);  // rounding to the grid costs half a step
  if (!(max_step > 0)) {
    return status(errc::limit_exceeded, "draco: coordinates this large (" + std::to_string(max_magnitude) +
                                            " Å) cannot keep 0.01 Å in float32; use the OFF format");
  }
  int bits = draco_settings::min_position_bits;
  while (bits <= draco_settings::max_position_bits &&
         static_cast<double>((std::uint64_t{1} << bits) - 1) * max_step < grid.range) {
    ++bits;
  }
  if (bits > draco_settings::max_position_bits) {
    return status(errc::limit_exceeded, "draco: the mesh extent needs more than 30 quantisation bits");
  }
  grid.bits = bits;
  return grid;
}

result<std::string> encode_draco(const surface_mesh& mesh) {
  if (const status valid = check_draco_input(mesh); !valid) return valid;
  const result<position_quantization> grid = choose_position_quantization(mesh);
  if (!grid) return grid.error();

  const std::unique_ptr<draco::Mesh> draco_mesh = to_draco_mesh(mesh);
  draco::Encoder encoder;
  encoder.SetSpeedOptions(draco_settings::encoding_speed, draco_settings::decoding_speed);
  encoder.SetAttributeExplicitQuantization(draco::GeometryAttribute::POSITION, grid->bits, 3, grid->origin,
                                           grid->range);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, draco_settings::normal_bits);
  draco::EncoderBuffer buffer;
  const draco::Status encoded = encoder.EncodeMeshToBuffer(*draco_mesh, &buffer);
  if (!encoded.ok()) {
    return status(errc::internal_error, std::string("draco: ") + encoded.error_msg_string());
  }
  return std::string(buffer.data(), buffer.size());
}

result<std::string> encode_mesh(const surface_mesh& mesh, mesh_format format) {
  switch (format) {
    case mesh_format::off: return encode_off(mesh);
    case mesh_format::draco: return encode_draco(mesh);
  }
  return status(errc::invalid_argument, "unknown mesh format");
}

std::string encode_msms_vert(const surface_mesh& mesh) {
  std::string out = "# MSMS-format vertices of a Gaussian molecular surface, written by tracemesh\n";
  out += "#vertex #sphere density probe_r\n";
  out += msms_counts_line(mesh, mesh.vertex_count());
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const vec3& p = mesh.positions[i];
    const vec3 normal = i < mesh.normals.size() ? mesh.normals[i] : vec3{};
    for (const double value : {p.x, p.y, p.z, normal.x, normal.y, normal.z}) {
      append_fixed(out, value, msms_decimals);
      out += ' ';
    }
    out += "0 ";
    append_integer(out, i < mesh.atom_index.size() ? mesh.atom_index[i] + 1ULL : 0ULL);
    out += " 2\n";
  }
  return out;
}

std::string encode_msms_face(const surface_mesh& mesh) {
  std::string out = "# MSMS-format triangles of a Gaussian molecular surface, written by tracemesh\n";
  out += "#faces #sphere density probe_r\n";
  out += msms_counts_line(mesh, mesh.triangle_count());
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t vertex : t) {
      append_integer(out, vertex + 1ULL);
      out += ' ';
    }
    out += "2 1\n";
  }
  return out;
}

}  // namespace tracemesh::proto
