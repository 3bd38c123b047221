#pragma once
// Reading every format of proto's format table back, and checking that what a client decodes is the certified
// mesh: the same vertices (within the format's position bound), normals, atom indices, components and triangles,
// and a mesh with no coincident vertex, no degenerate triangle, closed, manifold, consistently oriented and free
// of self-intersections. The readers are independent of the encoders: OFF and PLY are parsed here from their
// specifications, GLB by tinygltf (Debian libtinygltf-dev) and Draco payloads by Draco's own decoder.
#include <gtest/gtest.h>

#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "core/mesh.hpp"
#include "proto/mesh_encoders.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::testing {

/// A mesh as a client reads it; `component` is empty for formats that do not carry it (OFF).
struct decoded_mesh {
  surface_mesh mesh;
  std::vector<std::int32_t> component;
};

/// ASCII OFF: header, counts, "x y z" lines, "3 a b c" lines.
inline result<decoded_mesh> read_off(std::string_view text) {
  std::istringstream in{std::string(text)};
  std::string magic;
  std::size_t vertices = 0, faces = 0, edges = 0;
  if (!(in >> magic >> vertices >> faces >> edges) || magic != "OFF") return status(errc::invalid_input, "OFF header");
  decoded_mesh out;
  out.mesh.positions.resize(vertices);
  for (vec3& p : out.mesh.positions) {
    if (!(in >> p.x >> p.y >> p.z)) return status(errc::invalid_input, "OFF vertex");
  }
  out.mesh.triangles.resize(faces);
  for (auto& t : out.mesh.triangles) {
    int corners = 0;
    if (!(in >> corners >> t[0] >> t[1] >> t[2]) || corners != 3) return status(errc::invalid_input, "OFF face");
  }
  return out;
}

template <class T>
T read_little_endian(std::string_view bytes, std::size_t& at) {
  T value{};
  std::memcpy(&value, bytes.data() + at, sizeof(T));
  at += sizeof(T);
  return value;
}

/// Binary little-endian PLY with exactly the layout mesh_encoders.hpp documents (header checked line by line).
inline result<decoded_mesh> read_ply(std::string_view bytes) {
  const std::size_t header_end = bytes.find("end_header\n");
  if (header_end == std::string_view::npos) return status(errc::invalid_input, "PLY: no end_header");
  std::istringstream header{std::string(bytes.substr(0, header_end))};
  std::vector<std::string> lines;
  for (std::string line; std::getline(header, line);) {
    if (line.rfind("comment ", 0) != 0) lines.push_back(line);
  }
  std::size_t vertices = 0, faces = 0;
  const std::vector<std::string> expected = {"ply", "format binary_little_endian 1.0", "element vertex *",
                                             "property float x", "property float y", "property float z",
                                             "property float nx", "property float ny", "property float nz",
                                             "property uint atom_index", "property int component", "element face *",
                                             "property list uchar uint vertex_indices"};
  if (lines.size() != expected.size()) return status(errc::invalid_input, "PLY: unexpected header");
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& want = expected[i];
    if (want.back() == '*') {
      const std::string prefix = want.substr(0, want.size() - 1);
      if (lines[i].rfind(prefix, 0) != 0) return status(errc::invalid_input, "PLY header line " + lines[i]);
      (i == 2 ? vertices : faces) = std::stoull(lines[i].substr(prefix.size()));
    } else if (lines[i] != want) {
      return status(errc::invalid_input, "PLY header line " + lines[i]);
    }
  }
  std::size_t at = header_end + std::strlen("end_header\n");
  if (bytes.size() != at + vertices * 32 + faces * 13) return status(errc::invalid_input, "PLY: body size");
  decoded_mesh out;
  for (std::size_t v = 0; v < vertices; ++v) {
    vec3 p, n;
    for (int axis = 0; axis < 3; ++axis) p[axis] = read_little_endian<float>(bytes, at);
    for (int axis = 0; axis < 3; ++axis) n[axis] = read_little_endian<float>(bytes, at);
    out.mesh.positions.push_back(p);
    out.mesh.normals.push_back(n);
    out.mesh.atom_index.push_back(read_little_endian<std::uint32_t>(bytes, at));
    out.component.push_back(read_little_endian<std::int32_t>(bytes, at));
  }
  for (std::size_t f = 0; f < faces; ++f) {
    if (read_little_endian<std::uint8_t>(bytes, at) != 3) return status(errc::invalid_input, "PLY: not a triangle");
    std::array<std::uint32_t, 3> t{};
    for (std::uint32_t& corner : t) corner = read_little_endian<std::uint32_t>(bytes, at);
    out.mesh.triangles.push_back(t);
  }
  return out;
}

/// The float values of an uncompressed accessor (FLOAT components, tightly packed).
inline std::vector<float> gltf_floats(const tinygltf::Model& model, int accessor_index) {
  const tinygltf::Accessor& accessor = model.accessors.at(static_cast<std::size_t>(accessor_index));
  const tinygltf::BufferView& view = model.bufferViews.at(static_cast<std::size_t>(accessor.bufferView));
  const std::vector<unsigned char>& data = model.buffers.at(static_cast<std::size_t>(view.buffer)).data;
  const std::size_t count = accessor.count * static_cast<std::size_t>(tinygltf::GetNumComponentsInType(
                                                 static_cast<std::uint32_t>(accessor.type)));
  std::vector<float> values(count);
  std::memcpy(values.data(), data.data() + view.byteOffset + accessor.byteOffset, count * sizeof(float));
  return values;
}

/// GLB read by tinygltf; a KHR_draco_mesh_compression primitive is decoded by Draco through the extension's
/// attribute ids, an uncompressed one from its accessors.
inline result<decoded_mesh> read_glb(std::string_view bytes) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  if (!loader.LoadBinaryFromMemory(&model, &error, &warning, reinterpret_cast<const unsigned char*>(bytes.data()),
                                   static_cast<unsigned>(bytes.size()))) {
    return status(errc::invalid_input, "GLB: " + error);
  }
  if (model.meshes.size() != 1 || model.meshes[0].primitives.size() != 1) {
    return status(errc::invalid_input, "GLB: expected one mesh with one primitive");
  }
  const tinygltf::Primitive& primitive = model.meshes[0].primitives[0];
  decoded_mesh out;
  const auto draco = primitive.extensions.find("KHR_draco_mesh_compression");
  if (draco != primitive.extensions.end()) {
    const tinygltf::BufferView& view =
        model.bufferViews.at(static_cast<std::size_t>(draco->second.Get("bufferView").GetNumberAsInt()));
    const auto* data = model.buffers.at(static_cast<std::size_t>(view.buffer)).data.data() + view.byteOffset;
    // The extension names the Draco unique id of every attribute: decode_draco reads them by the ids of
    // draco_settings, so check that the document says the same.
    const tinygltf::Value& ids = draco->second.Get("attributes");
    if (ids.Get("POSITION").GetNumberAsInt() != 0 || ids.Get("NORMAL").GetNumberAsInt() != 1 ||
        ids.Get("_ATOM_INDEX").GetNumberAsInt() != static_cast<int>(proto::draco_settings::atom_index_unique_id) ||
        ids.Get("_COMPONENT").GetNumberAsInt() != static_cast<int>(proto::draco_settings::component_unique_id)) {
      return status(errc::invalid_input, "GLB: unexpected Draco attribute ids");
    }
    result<surface_mesh> decoded =
        proto::decode_draco(std::string_view(reinterpret_cast<const char*>(data), view.byteLength), &out.component);
    if (!decoded) return decoded.error();
    out.mesh = std::move(*decoded);
    return out;
  }
  const std::vector<float> positions = gltf_floats(model, primitive.attributes.at("POSITION"));
  const std::vector<float> normals = gltf_floats(model, primitive.attributes.at("NORMAL"));
  const std::vector<float> atoms = gltf_floats(model, primitive.attributes.at("_ATOM_INDEX"));
  const std::vector<float> components = gltf_floats(model, primitive.attributes.at("_COMPONENT"));
  for (std::size_t v = 0; v < atoms.size(); ++v) {
    out.mesh.positions.push_back({positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
    out.mesh.normals.push_back({normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]});
    out.mesh.atom_index.push_back(static_cast<std::uint32_t>(atoms[v]));
    out.component.push_back(static_cast<std::int32_t>(components[v]));
  }
  const tinygltf::Accessor& indices = model.accessors.at(static_cast<std::size_t>(primitive.indices));
  const tinygltf::BufferView& view = model.bufferViews.at(static_cast<std::size_t>(indices.bufferView));
  if (indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT || indices.count % 3 != 0) {
    return status(errc::invalid_input, "GLB: indices are not uint32 triangles");
  }
  out.mesh.triangles.resize(indices.count / 3);
  std::memcpy(out.mesh.triangles.data(), model.buffers[0].data.data() + view.byteOffset, indices.count * 4);
  return out;
}

inline result<decoded_mesh> read_delivered(std::string_view bytes, proto::mesh_format format) {
  switch (format) {
    case proto::mesh_format::off: return read_off(bytes);
    case proto::mesh_format::draco: {
      decoded_mesh out;
      result<surface_mesh> decoded = proto::decode_draco(bytes, &out.component);
      if (!decoded) return decoded.error();
      out.mesh = std::move(*decoded);
      return out;
    }
    case proto::mesh_format::glb:
    case proto::mesh_format::glb_raw: return read_glb(bytes);
    case proto::mesh_format::ply: return read_ply(bytes);
  }
  return status(errc::invalid_argument, "unknown format");
}

/// Largest distance, Å, a format may move a vertex: Draco's bound; float32 rounding; OFF's 1e-6 Å resolution.
inline double position_bound(proto::mesh_format format) {
  switch (proto::format_info(format).positions) {
    case proto::position_encoding::draco_grid: return proto::draco_settings::max_position_error;
    case proto::position_encoding::float32: return 1e-4;  // float32 at |x| < 1000 Å
    case proto::position_encoding::decimal: return 1e-6;
  }
  return 0;
}

inline std::size_t count_coincident(const std::vector<vec3>& positions) {
  std::set<std::tuple<double, double, double>> seen;
  std::size_t coincident = 0;
  for (const vec3& p : positions) coincident += seen.emplace(p.x, p.y, p.z).second ? 0 : 1;
  return coincident;
}

/// The decoded mesh, on its own: no coincident vertices, no degenerate triangle, closed, manifold, consistently
/// oriented, no self-intersection.
inline void expect_sound(const surface_mesh& decoded, const std::string& what) {
  EXPECT_EQ(count_coincident(decoded.positions), 0U) << what << ": coincident vertices";
  surface_mesh geometry;
  geometry.positions = decoded.positions;
  geometry.triangles = decoded.triangles;
  const mesh_report report = analyze_mesh(geometry);
  EXPECT_EQ(report.degenerate_triangles, 0U) << what << ": zero-area or degenerate triangles";
  EXPECT_EQ(report.invalid_triangles, 0U) << what;
  EXPECT_EQ(report.boundary_edges, 0U) << what << ": not closed";
  EXPECT_EQ(report.non_manifold_edges, 0U) << what;
  EXPECT_EQ(report.non_manifold_vertices, 0U) << what;
  EXPECT_EQ(report.inconsistently_oriented_edges, 0U) << what;
  EXPECT_EQ(report.self_intersections, 0U) << what;
}

using triangle_t = std::array<std::uint32_t, 3>;

inline triangle_t rotated_to_smallest(triangle_t t) {
  while (t[0] != std::min({t[0], t[1], t[2]})) t = {t[1], t[2], t[0]};
  return t;
}

/// For each decoded vertex, the original vertex it is: the nearest original vertex of the same atom (formats that
/// keep the order map i → i). Fails the test unless this is a bijection within `bound`.
inline std::vector<std::uint32_t> match_vertices(const surface_mesh& original, const surface_mesh& decoded,
                                                 bool same_order, double bound, const std::string& what) {
  std::vector<std::uint32_t> original_of(decoded.vertex_count());
  if (same_order) {
    for (std::uint32_t v = 0; v < original_of.size(); ++v) original_of[v] = v;
  } else {
    std::map<std::uint32_t, std::vector<std::uint32_t>> by_atom;
    for (std::uint32_t v = 0; v < original.vertex_count(); ++v) by_atom[original.atom_index[v]].push_back(v);
    for (std::uint32_t v = 0; v < decoded.vertex_count(); ++v) {
      double best = INFINITY;
      for (const std::uint32_t candidate : by_atom[decoded.atom_index[v]]) {
        const double d = distance(decoded.positions[v], original.positions[candidate]);
        if (d < best) best = d, original_of[v] = candidate;
      }
    }
  }
  std::vector<bool> used(original.vertex_count(), false);
  double worst = 0;
  for (std::uint32_t v = 0; v < decoded.vertex_count(); ++v) {
    const std::uint32_t o = original_of[v];
    EXPECT_FALSE(used[o]) << what << ": two decoded vertices are original vertex " << o;
    used[o] = true;
    worst = std::max(worst, distance(decoded.positions[v], original.positions[o]));
  }
  EXPECT_LE(worst, bound) << what << ": position error";
  return original_of;
}

/// `decoded` is `original` (a certified mesh with one component label per vertex, `components`, numbered by the
/// report's component order) as `format` delivers it.
inline void expect_delivered_faithfully(const surface_mesh& original, const mesh_report& report,
                                        const decoded_mesh& decoded, proto::mesh_format format) {
  const std::string what(proto::format_name(format));
  ASSERT_EQ(decoded.mesh.vertex_count(), original.vertex_count()) << what;
  ASSERT_EQ(decoded.mesh.triangle_count(), original.triangle_count()) << what;
  expect_sound(decoded.mesh, what);
  const bool carries_attributes = format != proto::mesh_format::off;
  const bool same_order = format != proto::mesh_format::draco && format != proto::mesh_format::glb;
  if (carries_attributes) {
    ASSERT_EQ(decoded.mesh.atom_index.size(), original.vertex_count()) << what;
  }
  const std::vector<std::uint32_t> original_of =
      match_vertices(original, decoded.mesh, same_order, position_bound(format), what);

  std::multiset<triangle_t> expected, got;
  for (const triangle_t& t : original.triangles) expected.insert(rotated_to_smallest(t));
  for (const triangle_t& t : decoded.mesh.triangles) {
    got.insert(rotated_to_smallest({original_of[t[0]], original_of[t[1]], original_of[t[2]]}));
  }
  EXPECT_TRUE(got == expected) << what << ": triangles (with their orientation) differ";
  if (!carries_attributes) return;

  std::size_t wrong_atoms = 0, bad_normals = 0;
  for (std::uint32_t v = 0; v < decoded.mesh.vertex_count(); ++v) {
    wrong_atoms += decoded.mesh.atom_index[v] != original.atom_index[original_of[v]] ? 1 : 0;
    bad_normals += dot(decoded.mesh.normals[v], original.normals[original_of[v]]) < std::cos(M_PI / 180) ? 1 : 0;
  }
  EXPECT_EQ(wrong_atoms, 0U) << what << ": atom indices";
  EXPECT_EQ(bad_normals, 0U) << what << ": normals off by more than 1 degree";

  // Components: equal on the two ends of every edge, and component c has the vertex count of the report's c-th
  // component (so the labels follow the report's order).
  ASSERT_EQ(decoded.component.size(), original.vertex_count()) << what;
  for (const triangle_t& t : decoded.mesh.triangles) {
    ASSERT_EQ(decoded.component[t[0]], decoded.component[t[1]]) << what;
    ASSERT_EQ(decoded.component[t[1]], decoded.component[t[2]]) << what;
  }
  std::vector<std::size_t> vertices_of(report.components.size(), 0);
  for (const std::int32_t c : decoded.component) {
    ASSERT_GE(c, 0) << what;
    ASSERT_LT(static_cast<std::size_t>(c), vertices_of.size()) << what;
    ++vertices_of[static_cast<std::size_t>(c)];
  }
  for (std::size_t c = 0; c < vertices_of.size(); ++c) {
    EXPECT_EQ(vertices_of[c], report.components[c].vertices) << what << ": component " << c;
  }
}

}  // namespace tracemesh::testing
