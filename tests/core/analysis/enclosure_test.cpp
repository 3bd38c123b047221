#include "core/analysis/enclosure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "support/analysis_meshes.hpp"

namespace tracemesh {
namespace {

using testing::append;
using testing::icosphere;
using testing::reverse_orientation;
using testing::tetrahedron;
using testing::torus;
using testing::translate;

/// An outer sphere (radius 10), the inward-facing surface of a cavity in it (radius 6), a small outward sphere
/// inside the cavity (radius 2: an island, enclosed though its volume is positive), and a separate sphere beside
/// the outer one (radius 3 at x = 20).
surface_mesh nested_shells() {
  surface_mesh mesh = icosphere(3, 10.0);
  surface_mesh cavity = icosphere(3, 6.0);
  reverse_orientation(cavity);
  append(mesh, cavity);
  append(mesh, icosphere(2, 2.0));
  append(mesh, icosphere(2, 3.0, {20, 0, 0}));
  return mesh;
}

mesh_report labelled_report(const surface_mesh& mesh) {
  analysis_options options;
  options.label_vertices = true;
  return analyze_mesh(mesh, options);
}

/// Index in report.components of the component whose area is closest to `area`.
std::size_t component_with_area(const mesh_report& report, double area) {
  std::size_t best = 0;
  for (std::size_t c = 0; c < report.components.size(); ++c) {
    if (std::abs(report.components[c].area - area) < std::abs(report.components[best].area - area)) best = c;
  }
  return best;
}

TEST(WindingNumber, IsOneInsideMinusOneInsideAnInwardSurfaceAndZeroOutside) {
  surface_mesh sphere = icosphere(2, 5.0);
  std::vector<std::uint32_t> all(sphere.triangles.size());
  for (std::uint32_t t = 0; t < all.size(); ++t) all[t] = t;
  EXPECT_NEAR(winding_number(sphere, all, {0, 0, 0}), 1.0, 1e-9);
  EXPECT_NEAR(winding_number(sphere, all, {4.5, 0.3, -0.2}), 1.0, 1e-9);
  EXPECT_NEAR(winding_number(sphere, all, {5.5, 0, 0}), 0.0, 1e-9);
  EXPECT_NEAR(winding_number(sphere, all, {100, 3, 1}), 0.0, 1e-9);
  reverse_orientation(sphere);
  EXPECT_NEAR(winding_number(sphere, all, {0, 0, 0}), -1.0, 1e-9);
}

TEST(EnclosedComponents, FlagsCavitiesAndIslandsInThemButNotOuterOrSeparateSurfaces) {
  const surface_mesh mesh = nested_shells();
  const mesh_report report = labelled_report(mesh);
  ASSERT_EQ(report.components.size(), 4u);
  const std::vector<bool> enclosed = enclosed_components(mesh, report);
  const double pi = std::acos(-1.0);
  const std::size_t outer = component_with_area(report, 4 * pi * 100);
  const std::size_t cavity = component_with_area(report, 4 * pi * 36);
  const std::size_t island = component_with_area(report, 4 * pi * 4);
  const std::size_t beside = component_with_area(report, 4 * pi * 9);
  EXPECT_FALSE(enclosed[outer]);
  EXPECT_TRUE(enclosed[cavity]);
  EXPECT_TRUE(report.components[cavity].cavity);
  EXPECT_TRUE(enclosed[island]) << "enclosed although its volume is positive";
  EXPECT_FALSE(report.components[island].cavity);
  EXPECT_FALSE(enclosed[beside]);
}

/// An axis-aligned box [lo, hi], 12 triangles, counter-clockwise from outside. Each face is split along the
/// diagonal from its first corner, so the face x = hi along y − lo.y = z − lo.z.
surface_mesh box_mesh(const vec3& lo, const vec3& hi) {
  surface_mesh mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.positions.push_back({(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z});
  }
  // Faces as quads a, b, c, d counter-clockwise from outside, split along a–c.
  const std::uint32_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

TEST(EnclosedComponents, RaysThroughEdgesAndVerticesAreDecidedByTheWindingNumber) {
  // Boxes whose first vertex (the one tested) has y = z: the rays along x from the two inside the outer box run
  // along the diagonal edge of its face x = 10; the ray from the one outside runs along its edge y = z = −10.
  surface_mesh mesh = box_mesh({-10, -10, -10}, {10, 10, 10});
  ASSERT_TRUE(analyze_mesh(mesh).topologically_certified());
  append(mesh, box_mesh({-2, -2, -2}, {2, 2, 2}));
  append(mesh, box_mesh({3, 3, 3}, {4, 4, 4}));
  append(mesh, box_mesh({-12, -10, -10}, {-11, -9, -9}));
  const mesh_report report = labelled_report(mesh);
  ASSERT_EQ(report.components.size(), 4u);
  ASSERT_TRUE(report.topologically_certified());
  const std::vector<bool> enclosed = enclosed_components(mesh, report);
  // Vertex 8k is the first vertex of box k.
  EXPECT_FALSE(enclosed[report.vertex_component[0]]);
  EXPECT_TRUE(enclosed[report.vertex_component[8]]);
  EXPECT_TRUE(enclosed[report.vertex_component[16]]);
  EXPECT_FALSE(enclosed[report.vertex_component[24]]);
}

TEST(EnclosedComponents, AgreesWithTheWindingNumberForThousandsOfIslands) {
  // An outer sphere and a torus beside it, and 0.3 Å tetrahedra on a 1.5 Å lattice around both: each tetrahedron
  // is enclosed exactly when the winding number of the sphere or of the torus at its first vertex says so.
  surface_mesh mesh = icosphere(3, 10.0);
  const std::size_t sphere_end = mesh.triangles.size();
  surface_mesh ring = torus(6.0, 2.0, 48, 24);
  translate(ring, {25, 0, 0});
  append(mesh, ring);
  std::vector<std::uint32_t> sphere_triangles, torus_triangles;
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
    (t < sphere_end ? sphere_triangles : torus_triangles).push_back(t);
  }
  std::vector<std::size_t> first_vertex;
  for (double x = -12.25; x < 36; x += 1.5) {
    for (double y = -12.25; y < 12.5; y += 1.5) {
      for (double z = -3.25; z < 3.5; z += 1.5) {
        const vec3 p{x, y, z};
        const double ring_distance = std::hypot(std::hypot(x - 25, y) - 6.0, z);
        if (std::abs(norm(p) - 10) < 0.8 || std::abs(ring_distance - 2) < 0.8) continue;  // clear of the shells
        first_vertex.push_back(mesh.positions.size());
        append(mesh, tetrahedron(p, p + vec3{0.3, 0, 0}, p + vec3{0, 0.3, 0}, p + vec3{0, 0, 0.3}));
      }
    }
  }
  ASSERT_GT(first_vertex.size(), 300u);
  const mesh_report report = labelled_report(mesh);
  ASSERT_EQ(report.components.size(), first_vertex.size() + 2);
  const std::vector<bool> enclosed = enclosed_components(mesh, report);
  std::size_t inside = 0;
  for (const std::size_t v : first_vertex) {
    const vec3& p = mesh.positions[v];
    const bool expected = std::abs(winding_number(mesh, sphere_triangles, p)) > 0.5 ||
                          std::abs(winding_number(mesh, torus_triangles, p)) > 0.5;
    inside += expected ? 1 : 0;
    EXPECT_EQ(enclosed[report.vertex_component[v]], expected) << "tetrahedron at " << p.x << " " << p.y << " " << p.z;
  }
  EXPECT_GT(inside, 50u);
  EXPECT_LT(inside, first_vertex.size() - 50);
}

TEST(RemoveComponents, KeepsTheOthersWholeWithTheirVertexAttributes) {
  surface_mesh mesh = nested_shells();
  mesh.normals.resize(mesh.positions.size());
  mesh.atom_index.resize(mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    mesh.normals[v] = normalized(mesh.positions[v] - vec3{mesh.positions[v].x > 15 ? 20.0 : 0.0, 0, 0});
    mesh.atom_index[v] = static_cast<std::uint32_t>(v);  // a per-vertex tag to follow
  }
  const surface_mesh before = mesh;
  const mesh_report report = labelled_report(mesh);
  const std::vector<bool> enclosed = enclosed_components(mesh, report);
  const std::size_t removed = remove_components(mesh, report.vertex_component, enclosed);

  std::size_t expected_removed = 0;
  for (std::size_t c = 0; c < enclosed.size(); ++c) expected_removed += enclosed[c] ? report.components[c].triangles : 0;
  EXPECT_EQ(removed, expected_removed);
  const mesh_report after = analyze_mesh(mesh);
  EXPECT_EQ(after.components.size(), 2u);
  EXPECT_EQ(after.cavities, 0u);
  EXPECT_TRUE(after.topologically_certified());
  EXPECT_EQ(after.unreferenced_vertices, 0u);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  ASSERT_EQ(mesh.atom_index.size(), mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const std::uint32_t original = mesh.atom_index[v];
    EXPECT_EQ(mesh.positions[v], before.positions[original]);
    EXPECT_EQ(mesh.normals[v], before.normals[original]);
  }
  // Nothing enclosed: nothing removed.
  const mesh_report kept = labelled_report(mesh);
  EXPECT_EQ(remove_components(mesh, kept.vertex_component, enclosed_components(mesh, kept)), 0u);
}

}  // namespace
}  // namespace tracemesh
