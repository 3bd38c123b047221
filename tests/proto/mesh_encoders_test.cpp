#include "proto/mesh_encoders.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "draco/compression/decode.h"
#include "draco/mesh/mesh.h"
#include "support/test_paths.hpp"

namespace tracemesh::proto {
namespace {

using triangle = std::array<std::uint32_t, 3>;

// ---------------------------------------------------------------------------------------------------------------
// Fixtures

/// A closed, manifold, outward-oriented icosphere (10·4^levels + 2 vertices) of `radius` Å around `center`, with
/// outward unit normals and atom_index[i] = atom_of(i).
surface_mesh icosphere(int levels, double radius, vec3 center,
                       std::uint32_t (*atom_of)(std::uint32_t) = [](std::uint32_t i) { return i; }) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<vec3> unit = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (vec3& p : unit) p = normalized(p);
  std::vector<triangle> faces = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    const auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto found = midpoints.find(key);
      if (found != midpoints.end()) return found->second;
      unit.push_back(normalized(unit[a] + unit[b]));
      const auto index = static_cast<std::uint32_t>(unit.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<triangle> finer;
    for (const triangle& f : faces) {
      const std::uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.insert(finer.end(), {{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}});
    }
    faces = std::move(finer);
  }
  surface_mesh mesh;
  for (std::uint32_t i = 0; i < unit.size(); ++i) {
    mesh.positions.push_back(center + radius * unit[i]);
    mesh.normals.push_back(unit[i]);
    mesh.atom_index.push_back(atom_of(i));
  }
  mesh.triangles = faces;
  return mesh;
}

/// A tetrahedron with awkward coordinates (many digits, a negative zero, a large magnitude).
surface_mesh tetrahedron() {
  surface_mesh mesh;
  mesh.positions = {{0.123456789012, -0.0, 1.5}, {-2.5, 10.25, 0.0}, {1234.56789, 3.0, -0.001953125}, {1, 1, 1}};
  mesh.triangles = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
  return mesh;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

/// The triangle rotated so that its smallest index comes first (same orientation).
triangle canonical_rotation(triangle t) {
  while (t[0] != std::min({t[0], t[1], t[2]})) t = {t[1], t[2], t[0]};
  return t;
}

std::multiset<triangle> canonical_triangles(const std::vector<triangle>& triangles) {
  std::multiset<triangle> set;
  for (const triangle& t : triangles) set.insert(canonical_rotation(t));
  return set;
}

std::unique_ptr<draco::Mesh> decode_in_process(const std::string& bytes) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    ADD_FAILURE() << decoded.status().error_msg_string();
    return nullptr;
  }
  return std::move(decoded).value();
}

vec3 draco_position(const draco::PointAttribute& attribute, draco::PointIndex point) {
  const auto value = attribute.GetValue<float, 3>(attribute.mapped_index(point));
  return {value[0], value[1], value[2]};
}

std::int32_t draco_atom_index(const draco::PointAttribute& attribute, draco::PointIndex point) {
  return attribute.GetValue<std::int32_t, 1>(attribute.mapped_index(point))[0];
}

/// Decodes with draco::Decoder and checks everything against `original`, whose atom_index must map each vertex to
/// a distinct value (`vertex_of` inverts it). Returns the largest position error, Å.
double check_draco_round_trip(const surface_mesh& original, const std::string& bytes,
                              std::uint32_t (*vertex_of)(std::int32_t)) {
  const std::unique_ptr<draco::Mesh> decoded = decode_in_process(bytes);
  if (!decoded) return INFINITY;
  EXPECT_EQ(decoded->num_points(), original.vertex_count());
  EXPECT_EQ(decoded->num_faces(), original.triangle_count());

  const draco::PointAttribute* positions = decoded->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  const draco::PointAttribute* normals = decoded->GetNamedAttribute(draco::GeometryAttribute::NORMAL);
  const int atom_attribute_id = decoded->GetAttributeIdByMetadataEntry("name", "atom_index");
  EXPECT_NE(positions, nullptr);
  EXPECT_NE(normals, nullptr);
  EXPECT_GE(atom_attribute_id, 0);
  if (!positions || !normals || atom_attribute_id < 0) return INFINITY;
  const draco::PointAttribute* atoms = decoded->attribute(atom_attribute_id);
  EXPECT_EQ(atoms->unique_id(), draco_settings::atom_index_unique_id);
  EXPECT_EQ(atoms->attribute_type(), draco::GeometryAttribute::GENERIC);
  EXPECT_EQ(atoms->data_type(), draco::DT_INT32);
  EXPECT_EQ(atoms->num_components(), 1);

  // Each decoded point names its original vertex through its atom index: exact round trip of the attribute.
  std::vector<std::uint32_t> original_of(decoded->num_points());
  std::set<std::uint32_t> seen;
  double max_error = 0;
  for (draco::PointIndex p(0); p < decoded->num_points(); ++p) {
    const std::int32_t atom = draco_atom_index(*atoms, p);
    const std::uint32_t vertex = vertex_of(atom);
    if (vertex >= original.vertex_count() || original.atom_index[vertex] != static_cast<std::uint32_t>(atom)) {
      ADD_FAILURE() << "atom index " << atom << " of point " << p.value() << " is not an original value";
      return INFINITY;
    }
    seen.insert(vertex);
    original_of[p.value()] = vertex;
    max_error = std::max(max_error, distance(draco_position(*positions, p), original.positions[vertex]));
    const auto normal = normals->GetValue<float, 3>(normals->mapped_index(p));
    EXPECT_GT(dot(vec3{normal[0], normal[1], normal[2]}, original.normals[vertex]), std::cos(std::numbers::pi / 180))
        << "normal error over 1 degree";
  }
  EXPECT_EQ(seen.size(), original.vertex_count()) << "atom indices must be a bijection";

  // Same triangles with the same orientation, whatever order Draco chose.
  std::vector<triangle> mapped;
  for (draco::FaceIndex f(0); f < decoded->num_faces(); ++f) {
    const auto& face = decoded->face(f);
    mapped.push_back({original_of[face[0].value()], original_of[face[1].value()], original_of[face[2].value()]});
  }
  EXPECT_EQ(canonical_triangles(mapped), canonical_triangles(original.triangles));
  return max_error;
}

std::uint32_t identity_vertex(std::int32_t atom) { return static_cast<std::uint32_t>(atom); }

// ---------------------------------------------------------------------------------------------------------------
// OFF

TEST(EncodeOff, HeaderCountsThenVerticesThenZeroBasedTriangles) {
  const surface_mesh mesh = tetrahedron();
  const std::vector<std::string> lines = lines_of(*encode_mesh(mesh, mesh_format::off));
  ASSERT_EQ(lines.size(), 2 + mesh.vertex_count() + mesh.triangle_count());
  EXPECT_EQ(lines[0], "OFF");
  EXPECT_EQ(lines[1], "4 4 0");
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    std::istringstream in(lines[2 + i]);
    double x = NAN, y = NAN, z = NAN;
    std::string rest;
    ASSERT_TRUE(in >> x >> y >> z) << lines[2 + i];
    EXPECT_FALSE(in >> rest) << "three numbers per vertex line";
    const vec3& p = mesh.positions[i];
    EXPECT_NEAR(x, p.x, 5e-9 * std::max(1.0, std::fabs(p.x)));
    EXPECT_NEAR(y, p.y, 5e-9 * std::max(1.0, std::fabs(p.y)));
    EXPECT_NEAR(z, p.z, 5e-9 * std::max(1.0, std::fabs(p.z)));
  }
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f) {
    const auto& t = mesh.triangles[f];
    EXPECT_EQ(lines[2 + mesh.vertex_count() + f],
              "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]));
  }
}

TEST(EncodeOff, NineSignificantDigitsAndNoNegativeZero) {
  const std::vector<std::string> lines = lines_of(*encode_mesh(tetrahedron(), mesh_format::off));
  EXPECT_EQ(lines[2], "0.123456789 0 1.5");
  EXPECT_EQ(lines[4], "1234.56789 3 -0.001953125");
}

TEST(EncodeOff, EmptyMesh) { EXPECT_EQ(*encode_mesh(surface_mesh{}, mesh_format::off), "OFF\n0 0 0\n"); }

TEST(EncodeOff, Deterministic) {
  const surface_mesh mesh = icosphere(2, 10, {1, 2, 3});
  const surface_mesh copy = mesh;
  EXPECT_EQ(*encode_mesh(mesh, mesh_format::off), *encode_mesh(copy, mesh_format::off));
}

// ---------------------------------------------------------------------------------------------------------------
// Draco

TEST(EncodeDraco, RoundTripsInProcessWithExactAtomIndices) {
  const surface_mesh mesh = icosphere(3, 20, {5, -3, 12});
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(bytes) << bytes.error().message();
  EXPECT_LE(check_draco_round_trip(mesh, *bytes, identity_vertex), draco_settings::max_position_error);
}

TEST(EncodeDraco, LargeAtomIndicesRoundTripExactly) {
  // Atom indices near the 2,000,000-atom limit and far from vertex order.
  const auto atom_of = [](std::uint32_t vertex) { return 1'999'999U - 7 * vertex; };
  const auto vertex_of = [](std::int32_t atom) { return (1'999'999U - static_cast<std::uint32_t>(atom)) / 7; };
  const surface_mesh mesh = icosphere(2, 15, {0, 0, 0}, atom_of);
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(bytes) << bytes.error().message();
  EXPECT_LE(check_draco_round_trip(mesh, *bytes, vertex_of), draco_settings::max_position_error);
}

TEST(EncodeDraco, QuantizationBoundHoldsOnA500AngstromBox) {
  const surface_mesh mesh = icosphere(4, 250, {0.37, -0.81, 0.29});
  const result<position_quantization> grid = choose_position_quantization(mesh);
  ASSERT_TRUE(grid) << grid.error().message();
  EXPECT_GE(grid->bits, 16) << "500 Å at ≤ 0.0115 Å spacing needs 16 bits";
  EXPECT_LE(grid->bits, 17) << "and not much more";
  EXPECT_GE(grid->range, 500.0F);
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(bytes) << bytes.error().message();
  const double max_error = check_draco_round_trip(mesh, *bytes, identity_vertex);
  EXPECT_LE(max_error, draco_settings::max_position_error);
  EXPECT_GT(max_error, 1e-4) << "the error is quantisation, not float rounding alone: the bound is not vacuous";
}

TEST(EncodeDraco, QuantizationBoundHoldsFarFromTheOrigin) {
  // Float32 spacing at 5,000 Å is 0.5 mÅ: the grid must leave room for it.
  const surface_mesh mesh = icosphere(3, 250, {5000, -5000, 4000});
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(bytes) << bytes.error().message();
  EXPECT_LE(check_draco_round_trip(mesh, *bytes, identity_vertex), draco_settings::max_position_error);
}

TEST(EncodeDraco, SmallMeshesUseTheMinimumBits) {
  const result<position_quantization> grid = choose_position_quantization(icosphere(1, 1, {0, 0, 0}));
  ASSERT_TRUE(grid);
  EXPECT_EQ(grid->bits, draco_settings::min_position_bits);
}

TEST(EncodeDraco, CoordinatesTooLargeForFloat32AreALimit) {
  const result<std::string> bytes = encode_mesh(icosphere(1, 10, {1e6, 0, 0}), mesh_format::draco);
  ASSERT_FALSE(bytes);
  EXPECT_EQ(bytes.error().code(), errc::limit_exceeded);
}

TEST(EncodeDraco, AMeshNoGridCarriesIsRefusedNamingTheFormatsThatCarryIt) {
  // Two vertices 1e-7 Å apart: every grid up to the most bits merges them.
  surface_mesh mesh = icosphere(2, 10, {0, 0, 0});
  const auto first = mesh.triangles[0];
  mesh.positions[first[1]] = mesh.positions[first[0]] + vec3{1e-7, 0, 0};
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_FALSE(bytes);
  EXPECT_EQ(bytes.error().code(), errc::limit_exceeded);
  EXPECT_NE(bytes.error().message().find("quantisation breaks this mesh"), std::string::npos) << bytes.error().message();
  EXPECT_NE(bytes.error().message().find("carry it: off, glb-raw, ply"), std::string::npos) << bytes.error().message();
  EXPECT_TRUE(encode_mesh(mesh, mesh_format::off)) << "the named formats do carry it";
}

TEST(EncodeDraco, DeterministicBytes) {
  const surface_mesh mesh = icosphere(3, 30, {1, 2, 3});
  const surface_mesh copy = mesh;
  const result<std::string> first = encode_mesh(mesh, mesh_format::draco);
  const result<std::string> second = encode_mesh(copy, mesh_format::draco);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(*first, *second);
  surface_mesh moved = mesh;
  moved.positions[0].x += 0.5;
  const result<std::string> other = encode_mesh(moved, mesh_format::draco);
  ASSERT_TRUE(other);
  EXPECT_NE(*other, *first) << "the bytes depend on the geometry";
}

TEST(EncodeDraco, OptionalAttributesMayBeAbsent) {
  surface_mesh mesh = icosphere(2, 10, {0, 0, 0});
  mesh.normals.clear();
  mesh.atom_index.clear();
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(bytes) << bytes.error().message();
  const std::unique_ptr<draco::Mesh> decoded = decode_in_process(*bytes);
  ASSERT_NE(decoded, nullptr);
  EXPECT_EQ(decoded->num_points(), mesh.vertex_count());
  EXPECT_EQ(decoded->GetNamedAttribute(draco::GeometryAttribute::NORMAL), nullptr);
  EXPECT_EQ(decoded->GetAttributeIdByMetadataEntry("name", "atom_index"), -1);
}

TEST(EncodeDraco, RejectsMalformedMeshesWithoutCrashing) {
  const auto expect_invalid = [](const surface_mesh& mesh, const char* what) {
    const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
    ASSERT_FALSE(bytes) << what;
    EXPECT_EQ(bytes.error().code(), errc::invalid_argument) << what;
  };
  expect_invalid(surface_mesh{}, "empty");
  surface_mesh mesh = icosphere(1, 10, {0, 0, 0});
  mesh.triangles.clear();
  expect_invalid(mesh, "no triangles");
  mesh = icosphere(1, 10, {0, 0, 0});
  mesh.triangles[3][1] = static_cast<std::uint32_t>(mesh.vertex_count());
  expect_invalid(mesh, "index past the end");
  mesh = icosphere(1, 10, {0, 0, 0});
  mesh.normals.pop_back();
  expect_invalid(mesh, "normals of the wrong size");
  mesh = icosphere(1, 10, {0, 0, 0});
  mesh.atom_index.push_back(0);
  expect_invalid(mesh, "atom_index of the wrong size");
  mesh = icosphere(1, 10, {0, 0, 0});
  mesh.positions[5].y = NAN;
  expect_invalid(mesh, "NaN coordinate");
}

/// Runs Debian's draco_decoder on `bytes`; returns the OBJ text ("" on failure).
std::string decode_with_cli(const std::string& bytes) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("tracemesh_proto_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path drc = dir / "mesh.drc", obj = dir / "mesh.obj";
  std::ofstream(drc, std::ios::binary) << bytes;
  const std::string command = std::string(TRACEMESH_DRACO_DECODER) + " -i " + drc.string() + " -o " +
                              obj.string() + " > " + (dir / "log").string() + " 2>&1";
  const int exit_code = std::system(command.c_str());
  std::ifstream in(obj);
  std::stringstream text;
  text << in.rdbuf();
  std::filesystem::remove_all(dir);
  EXPECT_EQ(exit_code, 0) << command;
  return text.str();
}

TEST(EncodeDraco, DecodesWithDebiansDracoDecoder) {
  if (std::string(TRACEMESH_DRACO_DECODER).empty()) GTEST_SKIP() << "draco_decoder not installed";
  const surface_mesh mesh = icosphere(4, 250, {0.37, -0.81, 0.29});  // the 500 Å box
  const result<std::string> bytes = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(bytes) << bytes.error().message();
  const std::string obj = decode_with_cli(*bytes);

  std::vector<vec3> positions;
  std::vector<triangle> faces;
  for (const std::string& line : lines_of(obj)) {
    std::istringstream in(line);
    std::string tag;
    in >> tag;
    if (tag == "v") {
      vec3 p;
      ASSERT_TRUE(in >> p.x >> p.y >> p.z) << line;
      positions.push_back(p);
    } else if (tag == "f") {
      triangle t{};
      for (std::uint32_t& corner : t) {
        std::string token;  // "v", "v/vt" or "v//vn": the vertex is the first number, 1-based
        ASSERT_TRUE(in >> token) << line;
        corner = static_cast<std::uint32_t>(std::stoul(token)) - 1;
      }
      faces.push_back(t);
    }
  }
  ASSERT_EQ(positions.size(), mesh.vertex_count());
  ASSERT_EQ(faces.size(), mesh.triangle_count());

  // The CLI drops the atom index, so match each decoded vertex to its nearest original; the matching must be a
  // bijection within the error bound, and the faces must be the original ones.
  std::vector<std::uint32_t> original_of(positions.size());
  std::set<std::uint32_t> matched;
  double max_error = 0;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    double best = INFINITY;
    for (std::uint32_t v = 0; v < mesh.vertex_count(); ++v) {
      const double d = squared_norm(positions[i] - mesh.positions[v]);
      if (d < best) {
        best = d;
        original_of[i] = v;
      }
    }
    matched.insert(original_of[i]);
    max_error = std::max(max_error, std::sqrt(best));
  }
  EXPECT_EQ(matched.size(), mesh.vertex_count());
  // The OBJ writer prints 6 decimals: allow its 5e-7 Å per coordinate on top of the bound.
  EXPECT_LE(max_error, draco_settings::max_position_error + 1e-6);
  for (triangle& t : faces) t = {original_of[t[0]], original_of[t[1]], original_of[t[2]]};
  EXPECT_EQ(canonical_triangles(faces), canonical_triangles(mesh.triangles));
}

// ---------------------------------------------------------------------------------------------------------------
// encode_mesh and MSMS

TEST(EncodeMesh, DispatchesOnTheFormat) {
  const surface_mesh mesh = icosphere(1, 5, {0, 0, 0});
  const result<std::string> off = encode_mesh(mesh, mesh_format::off);
  ASSERT_TRUE(off);
  EXPECT_EQ(*off, *encode_mesh(mesh, mesh_format::off));
  const result<std::string> draco = encode_mesh(mesh, mesh_format::draco);
  ASSERT_TRUE(draco);
  EXPECT_EQ(*draco, *encode_mesh(mesh, mesh_format::draco));
}

TEST(EncodeMsms, VertFileHasOneLinePerVertexWithOneBasedAtoms) {
  const surface_mesh mesh = icosphere(1, 5, {1, 2, 3}, [](std::uint32_t i) { return 100 + i; });
  const std::vector<std::string> lines = lines_of(encode_msms_vert(mesh));
  ASSERT_EQ(lines.size(), 3 + mesh.vertex_count());
  EXPECT_EQ(lines[0][0], '#');
  EXPECT_EQ(lines[1][0], '#');
  std::istringstream header(lines[2]);
  std::size_t vertices = 0, spheres = 0;
  double density = 0, probe = -1;
  ASSERT_TRUE(header >> vertices >> spheres >> density >> probe);
  EXPECT_EQ(vertices, mesh.vertex_count());
  EXPECT_EQ(spheres, 100 + mesh.vertex_count());
  EXPECT_GT(density, 0);
  EXPECT_EQ(probe, 0);
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    std::istringstream in(lines[3 + i]);
    vec3 p, n;
    int face = -1, type = -1;
    std::uint64_t sphere = 0;
    ASSERT_TRUE(in >> p.x >> p.y >> p.z >> n.x >> n.y >> n.z >> face >> sphere >> type) << lines[3 + i];
    EXPECT_LE(distance(p, mesh.positions[i]), 1e-6);
    EXPECT_LE(distance(n, mesh.normals[i]), 1e-6);
    EXPECT_EQ(sphere, mesh.atom_index[i] + 1ULL);
  }
}

TEST(EncodeMsms, FaceFileHasOneBasedTriangles) {
  const surface_mesh mesh = icosphere(1, 5, {0, 0, 0});
  const std::vector<std::string> lines = lines_of(encode_msms_face(mesh));
  ASSERT_EQ(lines.size(), 3 + mesh.triangle_count());
  std::istringstream header(lines[2]);
  std::size_t faces = 0;
  ASSERT_TRUE(header >> faces);
  EXPECT_EQ(faces, mesh.triangle_count());
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f) {
    std::istringstream in(lines[3 + f]);
    std::uint64_t a = 0, b = 0, c = 0;
    ASSERT_TRUE(in >> a >> b >> c) << lines[3 + f];
    EXPECT_EQ(a, mesh.triangles[f][0] + 1ULL);
    EXPECT_EQ(b, mesh.triangles[f][1] + 1ULL);
    EXPECT_EQ(c, mesh.triangles[f][2] + 1ULL);
  }
}

}  // namespace
}  // namespace tracemesh::proto
