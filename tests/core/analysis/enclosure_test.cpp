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
