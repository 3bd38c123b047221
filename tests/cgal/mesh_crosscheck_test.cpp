// analyze_mesh (core/mesh_analysis.hpp) against an independent implementation: CGAL 5.5's Polygon Mesh Processing
// with exact predicates (cgal_check.hpp), on the synthetic meshes of tests/core/mesh_analysis_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cgal/cgal_check.hpp"
#include "core/analysis/mesh_analysis.hpp"
#include "support/analysis_meshes.hpp"

namespace tracemesh::testing {
namespace {

/// Everything both sides measure must agree; on manifold meshes CGAL's verdicts are the reference.
void expect_agreement(const surface_mesh& mesh, const char* name) {
  SCOPED_TRACE(name);
  const mesh_report report = analyze_mesh(mesh);
  const cgal_certificate cgal = check_with_cgal(mesh);
  const bool manifold = report.non_manifold_edges == 0 && report.non_manifold_vertices == 0 &&
                        report.inconsistently_oriented_edges == 0 && report.degenerate_triangles == 0 &&
                        report.invalid_triangles == 0;
  EXPECT_EQ(cgal.polygon_mesh, manifold) << describe(cgal);
  if (!cgal.polygon_mesh) {
    EXPECT_FALSE(report.topologically_certified());
    return;
  }
  EXPECT_EQ(cgal.closed, report.boundary_edges == 0);
  EXPECT_EQ(cgal.self_intersecting_pairs, report.self_intersections);
  EXPECT_EQ(cgal.components, report.components.size());
  EXPECT_NEAR(report.area, cgal.area, 1e-9 * cgal.area);
  if (cgal.closed) {
    EXPECT_NEAR(report.volume, cgal.volume, 1e-9 * std::abs(cgal.volume) + 1e-12);
  }
  EXPECT_EQ(cgal.certified(), report.topologically_certified()) << describe(cgal);
  ASSERT_EQ(cgal.component_details.size(), report.components.size());
  for (std::size_t c = 0; c < report.components.size(); ++c) {
    EXPECT_NEAR(report.components[c].area, cgal.component_details[c].area, 1e-9 * cgal.component_details[c].area);
    if (cgal.closed && cgal.self_intersecting_pairs == 0) {
      // A cavity (negative volume) is a component that, taken alone, points inward.
      EXPECT_EQ(report.components[c].cavity, !cgal.component_details[c].outward_oriented) << "component " << c;
    }
  }
}

TEST(MeshCrosscheck, ClosedSurfaces) {
  expect_agreement(icosphere(4, 2.5, {1, -2, 3}), "icosphere");
  expect_agreement(torus(3, 1, 64, 32), "torus");
  surface_mesh two = icosphere(2, 1.0);
  append(two, icosphere(2, 2.0, {10, 0, 0}));
  expect_agreement(two, "two disjoint spheres");
}

TEST(MeshCrosscheck, Cavity) {
  surface_mesh mesh = icosphere(3, 3.0);
  surface_mesh inner = icosphere(3, 1.0, {0.2, -0.1, 0.3});
  reverse_orientation(inner);
  append(mesh, inner);
  expect_agreement(mesh, "sphere with a cavity");
}

TEST(MeshCrosscheck, Defects) {
  surface_mesh hole = icosphere(2);
  hole.triangles.erase(hole.triangles.begin() + 17);
  expect_agreement(hole, "hole");

  surface_mesh flipped = icosphere(1);
  std::swap(flipped.triangles[5][1], flipped.triangles[5][2]);
  expect_agreement(flipped, "flipped triangle");

  surface_mesh touching = tetrahedron({1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0});
  append(touching, tetrahedron({-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, {0, 0, 0}));
  expect_agreement(touching, "tetrahedra touching at coincident vertices");  // two components, touching

  surface_mesh fin;
  fin.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0.2}, {0.5, 0.2, 1}};
  fin.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  expect_agreement(fin, "three triangles on an edge");

  expect_agreement(flat_grid(6, 4), "flat grid");
}

TEST(MeshCrosscheck, SelfIntersections) {
  surface_mesh overlapping = icosphere(3, 1.0);
  append(overlapping, icosphere(3, 1.0, {1.1, 0.05, 0.02}));
  expect_agreement(overlapping, "overlapping spheres");

  // Crumpled spheres: folds between neighbouring triangles (shared vertices and edges) as well as separate ones.
  std::mt19937_64 random(3);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int round = 0; round < 3; ++round) {
    surface_mesh crumpled = icosphere(3);
    for (vec3& p : crumpled.positions) p += vec3{noise(random), noise(random), noise(random)};
    expect_agreement(crumpled, "crumpled sphere");
    EXPECT_GT(count_self_intersections(crumpled), 0u);  // the comparison is not vacuous
  }
}

TEST(MeshCrosscheck, TriangleSoupsAgreeWithCgalPredicates) {
  // Separate triangles (no shared indices): every pair is a plain triangle–triangle test, CGAL's exact
  // do_intersect is the reference. Includes exactly coplanar and touching configurations on a coarse lattice.
  std::mt19937_64 random(11);
  std::uniform_int_distribution<int> lattice(0, 6);
  std::uniform_real_distribution<double> coordinate(0.0, 4.0);
  for (int round = 0; round < 6; ++round) {
    surface_mesh soup;
    for (std::uint32_t t = 0; t < 300; ++t) {
      for (int k = 0; k < 3; ++k) {
        // Even rounds: random reals; odd rounds: small integers, so that many contacts are exact.
        soup.positions.push_back(round % 2 == 0 ? vec3{coordinate(random), coordinate(random), coordinate(random)}
                                                : vec3{double(lattice(random)), double(lattice(random)),
                                                       double(round == 5 ? 0 : lattice(random))});
      }
      soup.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
    }
    const mesh_report report = analyze_mesh(soup);
    // Degenerate (collinear) triangles are not tested by analyze_mesh: drop them from the reference too.
    surface_mesh tested;
    tested.positions = soup.positions;
    for (const auto& t : soup.triangles) {
      const vec3 n = cross(soup.positions[t[1]] - soup.positions[t[0]], soup.positions[t[2]] - soup.positions[t[0]]);
      if (squared_norm(n) > 0) tested.triangles.push_back(t);
    }
    EXPECT_EQ(report.triangles - report.degenerate_triangles, tested.triangles.size()) << "round " << round;
    const std::size_t expected = cgal_count_intersecting_pairs_brute_force(tested);
    EXPECT_GT(expected, 0u) << "round " << round;
    EXPECT_EQ(report.self_intersections, expected) << "round " << round;
  }
}

}  // namespace
}  // namespace tracemesh::testing
