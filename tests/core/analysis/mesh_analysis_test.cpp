// Tests of core/analysis/mesh_analysis.hpp (and its exact predicates in core/analysis/): synthetic meshes with known area,
// volume, topology and defects; the exact predicates on near-degenerate inputs; the grid broad phase against a
// brute-force pair loop.
#include "core/analysis/mesh_analysis.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <numbers>
#include <random>

#include "core/analysis/analysis_fan_pairs.hpp"
#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_predicates.hpp"
#include "core/analysis/analysis_topology.hpp"
#include "core/analysis/triangle_intersection.hpp"
#include "support/analysis_meshes.hpp"

namespace tracemesh {
namespace {

using testing::append;
using testing::flat_grid;
using testing::icosphere;
using testing::reverse_orientation;
using testing::set_radial_normals;
using testing::tetrahedron;
using testing::torus;

constexpr double pi = std::numbers::pi;

double relative_error(double value, double expected) { return std::abs(value - expected) / std::abs(expected); }

/// Brute force over all pairs of tested (non-degenerate) triangles with the exact pair test: the reference for the
/// grid broad phase and the per-fan certificates.
std::size_t count_intersections_brute_force(const surface_mesh& mesh) {
  const std::vector<detail::triangle_defect> defects = detail::classify_triangles(mesh);
  std::size_t count = 0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    for (std::size_t j = i + 1; j < mesh.triangles.size(); ++j) {
      if (defects[i] != detail::triangle_defect::none || defects[j] != detail::triangle_defect::none) continue;
      if (detail::mesh_triangles_intersect(mesh.positions, mesh.triangles[i], mesh.triangles[j])) ++count;
    }
  }
  return count;
}

surface_mesh two_triangles(const std::array<vec3, 3>& t, const std::array<vec3, 3>& u) {
  surface_mesh mesh;
  mesh.positions = {t[0], t[1], t[2], u[0], u[1], u[2]};
  mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  return mesh;
}

// ---------------------------------------------------------------------------------------------------------------
// Closed surfaces with known geometry

TEST(MeshAnalysis, IcosphereMatchesSphereAndIsCertified) {
  const double radius = 2.5;
  const surface_mesh mesh = icosphere(4, radius, {1, -2, 3});
  const mesh_report report = analyze_mesh(mesh);

  EXPECT_EQ(report.vertices, 2562u);
  EXPECT_EQ(report.triangles, 5120u);
  ASSERT_EQ(report.components.size(), 1u);
  EXPECT_EQ(report.euler_characteristic, 2);
  EXPECT_EQ(report.genus, 0);
  EXPECT_EQ(report.components[0].genus, 0);
  EXPECT_EQ(report.components[0].boundary_loops, 0u);
  EXPECT_FALSE(report.components[0].cavity);
  EXPECT_EQ(report.cavities, 0u);
  // An inscribed polyhedron lies inside the sphere: both measures fall short, by well under 1 % at 5120 faces.
  const double sphere_area = 4 * pi * radius * radius;
  const double sphere_volume = 4.0 / 3.0 * pi * radius * radius * radius;
  EXPECT_LT(report.area, sphere_area);
  EXPECT_LT(report.volume, sphere_volume);
  EXPECT_LT(relative_error(report.area, sphere_area), 0.005);
  EXPECT_LT(relative_error(report.volume, sphere_volume), 0.01);
  EXPECT_DOUBLE_EQ(report.components[0].area, report.area);
  EXPECT_NEAR(report.achieved_density, 2562 / report.area, 1e-12);
  EXPECT_EQ(report.self_intersections, 0u);
  EXPECT_TRUE(report.topologically_certified());
}

TEST(MeshAnalysis, SphereDiscretisationErrorShrinksQuadratically) {
  // Halving the edge length (one subdivision) should cut the area and volume errors by about 4.
  const double sphere_area = 4 * pi;
  const double sphere_volume = 4.0 / 3.0 * pi;
  double previous_area_error = 0, previous_volume_error = 0;
  for (int level = 2; level <= 5; ++level) {
    const mesh_report report = analyze_mesh(icosphere(level), {.check_self_intersections = false});
    const double area_error = relative_error(report.area, sphere_area);
    const double volume_error = relative_error(report.volume, sphere_volume);
    if (level > 2) {
      EXPECT_GT(previous_area_error / area_error, 3.5) << "level " << level;
      EXPECT_LT(previous_area_error / area_error, 4.5) << "level " << level;
      EXPECT_GT(previous_volume_error / volume_error, 3.5) << "level " << level;
      EXPECT_LT(previous_volume_error / volume_error, 4.5) << "level " << level;
    }
    previous_area_error = area_error;
    previous_volume_error = volume_error;
  }
}

TEST(MeshAnalysis, TorusHasGenusOne) {
  const double major = 3, minor = 1;
  const mesh_report report = analyze_mesh(torus(major, minor, 96, 48));
  ASSERT_EQ(report.components.size(), 1u);
  EXPECT_EQ(report.euler_characteristic, 0);
  EXPECT_EQ(report.genus, 1);
  EXPECT_EQ(report.components[0].genus, 1);
  EXPECT_EQ(report.boundary_edges, 0u);
  EXPECT_EQ(report.self_intersections, 0u);
  EXPECT_TRUE(report.topologically_certified());
  EXPECT_LT(relative_error(report.area, 4 * pi * pi * major * minor), 0.005);
  EXPECT_LT(relative_error(report.volume, 2 * pi * pi * major * minor * minor), 0.01);
}

TEST(MeshAnalysis, DisjointSpheresAreTwoComponentsLargestFirst) {
  surface_mesh mesh = icosphere(2, 1.0, {0, 0, 0});
  append(mesh, icosphere(2, 2.0, {10, 0, 0}));  // the larger one comes second in the triangle order
  const mesh_report report = analyze_mesh(mesh);
  ASSERT_EQ(report.components.size(), 2u);
  EXPECT_NEAR(report.components[0].area / report.components[1].area, 4.0, 1e-9);
  EXPECT_NEAR(report.components[0].volume / report.components[1].volume, 8.0, 1e-9);
  EXPECT_EQ(report.components[0].vertices, 162u);
  EXPECT_EQ(report.components[0].triangles, 320u);
  EXPECT_EQ(report.euler_characteristic, 4);
  EXPECT_EQ(report.genus, 0);
  EXPECT_NEAR(report.area, report.components[0].area + report.components[1].area, 1e-9);
  EXPECT_TRUE(report.topologically_certified());
}

TEST(MeshAnalysis, VertexComponentsFollowTheReportOrder) {
  surface_mesh mesh = icosphere(2, 1.0, {0, 0, 0});
  const std::size_t small_vertices = mesh.vertex_count();
  append(mesh, icosphere(2, 2.0, {10, 0, 0}));  // larger, so component 0, though second in vertex order
  mesh.positions.push_back({50, 50, 50});       // used by no triangle
  analysis_options options;
  options.label_vertices = true;
  const mesh_report report = analyze_mesh(mesh, options);
  ASSERT_EQ(report.vertex_component.size(), mesh.vertex_count());
  for (std::size_t v = 0; v < small_vertices; ++v) EXPECT_EQ(report.vertex_component[v], 1U) << v;
  for (std::size_t v = small_vertices; v + 1 < mesh.vertex_count(); ++v) EXPECT_EQ(report.vertex_component[v], 0U);
  EXPECT_EQ(report.vertex_component.back(), std::numeric_limits<std::uint32_t>::max());
  EXPECT_TRUE(analyze_mesh(mesh).vertex_component.empty()) << "only when asked for";
}

TEST(MeshAnalysis, DegenerateTrianglesCountAlone) {
  surface_mesh mesh = icosphere(1);
  EXPECT_EQ(count_degenerate_triangles(mesh), 0U);
  const auto t = mesh.triangles[0];
  mesh.positions.push_back(0.25 * mesh.positions[t[0]] + 0.75 * mesh.positions[t[1]]);  // collinear corners
  mesh.triangles.push_back({t[0], t[1], static_cast<std::uint32_t>(mesh.positions.size() - 1)});
  mesh.triangles.push_back({t[0], t[0], t[1]});  // repeated index
  EXPECT_EQ(count_degenerate_triangles(mesh), 2U);
  EXPECT_EQ(count_degenerate_triangles(mesh), analyze_mesh(mesh).degenerate_triangles);
}

TEST(MeshAnalysis, EqualAreasKeepTriangleOrder) {
  // A 2 × 2 square and a 4 × 1 strip: both exactly 4 Å², told apart by their vertex counts (9 and 10).
  const surface_mesh square = flat_grid(2, 2);
  surface_mesh strip = flat_grid(4, 1);
  testing::translate(strip, {0, 0, 5});
  surface_mesh square_first = square, strip_first = strip;
  append(square_first, strip);
  append(strip_first, square);
  const mesh_report a = analyze_mesh(square_first), b = analyze_mesh(strip_first);
  ASSERT_EQ(a.components.size(), 2u);
  ASSERT_EQ(b.components.size(), 2u);
  ASSERT_EQ(a.components[0].area, a.components[1].area);
  EXPECT_EQ(a.components[0].vertices, 9u);
  EXPECT_EQ(b.components[0].vertices, 10u);
}

TEST(MeshAnalysis, ReversedInnerSphereIsACavity) {
  surface_mesh mesh = icosphere(3, 3.0);
  set_radial_normals(mesh, {});
  surface_mesh inner = icosphere(3, 1.0);
  reverse_orientation(inner);
  set_radial_normals(inner, {}, -1.0);  // the cavity's normals point into it, towards the centre
  append(mesh, inner);

  const mesh_report report = analyze_mesh(mesh);
  ASSERT_EQ(report.components.size(), 2u);
  EXPECT_EQ(report.cavities, 1u);
  EXPECT_FALSE(report.components[0].cavity);
  EXPECT_TRUE(report.components[1].cavity);
  EXPECT_GT(report.components[0].volume, 0);
  EXPECT_LT(report.components[1].volume, 0);
  EXPECT_NEAR(report.components[1].volume / report.components[0].volume, -1.0 / 27.0, 1e-9);
  EXPECT_NEAR(report.volume, report.components[0].volume + report.components[1].volume, 1e-9);
  EXPECT_EQ(report.inward_oriented_components, 0u);
  EXPECT_TRUE(report.topologically_certified());
}

TEST(MeshAnalysis, InwardNormalsAreDetected) {
  surface_mesh mesh = icosphere(3);
  set_radial_normals(mesh, {}, -1.0);
  EXPECT_EQ(analyze_mesh(mesh).inward_oriented_components, 1u);
  EXPECT_FALSE(analyze_mesh(mesh).topologically_certified());

  set_radial_normals(mesh, {}, 1.0);
  EXPECT_EQ(analyze_mesh(mesh).inward_oriented_components, 0u);

  mesh.normals.pop_back();  // not one normal per vertex: orientation cannot be confirmed
  EXPECT_EQ(analyze_mesh(mesh).inward_oriented_components, 1u);
  mesh.normals.clear();  // no normals: nothing to compare
  EXPECT_EQ(analyze_mesh(mesh).inward_oriented_components, 0u);
}

// ---------------------------------------------------------------------------------------------------------------
// Defects

TEST(MeshAnalysis, HoleGivesBoundaryEdges) {
  surface_mesh mesh = icosphere(2);
  mesh.triangles.erase(mesh.triangles.begin() + 17);
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_EQ(report.boundary_edges, 3u);
  ASSERT_EQ(report.components.size(), 1u);
  EXPECT_EQ(report.components[0].boundary_loops, 1u);
  EXPECT_EQ(report.euler_characteristic, 1);
  EXPECT_EQ(report.genus, 0);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_EQ(report.non_manifold_vertices, 0u);
  EXPECT_FALSE(report.topologically_certified());
}

TEST(MeshAnalysis, FlatGridAndAnnulus) {
  const std::uint32_t n = 5;
  surface_mesh disk = flat_grid(n, n);
  mesh_report report = analyze_mesh(disk);
  EXPECT_EQ(report.boundary_edges, 4 * n);
  EXPECT_EQ(report.euler_characteristic, 1);
  EXPECT_EQ(report.components[0].boundary_loops, 1u);
  EXPECT_EQ(report.genus, 0);
  EXPECT_DOUBLE_EQ(report.area, double(n * n));
  EXPECT_EQ(report.self_intersections, 0u);  // coplanar neighbours sharing edges and vertices do not count

  // Remove the middle square: an annulus has χ = 0, two boundary loops, and still genus 0.
  const std::size_t middle_square = (n / 2) * n + n / 2;
  disk.triangles.erase(disk.triangles.begin() + static_cast<std::ptrdiff_t>(2 * middle_square),
                       disk.triangles.begin() + static_cast<std::ptrdiff_t>(2 * middle_square + 2));
  report = analyze_mesh(disk);
  EXPECT_EQ(report.boundary_edges, 4 * n + 4);
  EXPECT_EQ(report.euler_characteristic, 0);
  EXPECT_EQ(report.components[0].boundary_loops, 2u);
  EXPECT_EQ(report.genus, 0);
}

TEST(MeshAnalysis, ThreeTrianglesOnAnEdgeAreNonManifold) {
  surface_mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0.2}, {0.5, 0.2, 1}};
  mesh.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_EQ(report.non_manifold_edges, 1u);
  EXPECT_EQ(report.boundary_edges, 6u);
  EXPECT_EQ(report.inconsistently_oriented_edges, 0u);  // only two-triangle edges can be inconsistent
  EXPECT_EQ(report.non_manifold_vertices, 0u);          // the fans around 0 and 1 are still edge-connected
  EXPECT_FALSE(report.topologically_certified());
}

/// Two tetrahedra meeting at the origin, one on each side: with `share_vertex` the origin is one vertex.
surface_mesh tetrahedra_touching_at_origin(bool share_vertex) {
  surface_mesh mesh = tetrahedron({1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0});
  append(mesh, tetrahedron({-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, {0, 0, 0}));
  if (share_vertex) {
    for (auto& triangle : mesh.triangles) {
      for (std::uint32_t& v : triangle) v = v == 7 ? 3 : v;
    }
    mesh.positions.pop_back();
  }
  return mesh;
}

TEST(MeshAnalysis, TetrahedraTouchingAtASharedVertexAreNonManifold) {
  const mesh_report report = analyze_mesh(tetrahedra_touching_at_origin(true));
  EXPECT_EQ(report.non_manifold_vertices, 1u);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_EQ(report.boundary_edges, 0u);
  EXPECT_EQ(report.inconsistently_oriented_edges, 0u);
  ASSERT_EQ(report.components.size(), 1u);  // connected through the shared vertex
  EXPECT_EQ(report.euler_characteristic, 7 - 12 + 8);
  EXPECT_NEAR(report.volume, 2.0 / 6.0, 1e-12);
  EXPECT_EQ(report.self_intersections, 0u);  // they meet only at the shared vertex
  EXPECT_FALSE(report.topologically_certified());
}

TEST(MeshAnalysis, TetrahedraTouchingAtCoincidentVerticesIntersect) {
  const mesh_report report = analyze_mesh(tetrahedra_touching_at_origin(false));
  EXPECT_EQ(report.non_manifold_vertices, 0u);
  EXPECT_EQ(report.components.size(), 2u);
  // Three faces of each tetrahedron contain the origin: every such pair touches there.
  EXPECT_EQ(report.self_intersections, 9u);
}

TEST(MeshAnalysis, FlippedTriangleIsInconsistentlyOriented) {
  surface_mesh mesh = icosphere(1);
  std::swap(mesh.triangles[5][1], mesh.triangles[5][2]);
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_EQ(report.inconsistently_oriented_edges, 3u);
  EXPECT_EQ(report.boundary_edges, 0u);
  EXPECT_EQ(report.non_manifold_edges, 0u);
  EXPECT_FALSE(report.topologically_certified());
}

TEST(MeshAnalysis, DegenerateTrianglesAreCounted) {
  const surface_mesh sphere = icosphere(1);
  {
    surface_mesh mesh = sphere;
    mesh.triangles.push_back({0, 0, 1});  // repeated index
    const mesh_report report = analyze_mesh(mesh);
    EXPECT_EQ(report.degenerate_triangles, 1u);
    EXPECT_EQ(report.boundary_edges, 0u);  // ill-formed triangles take no part in topology
    EXPECT_FALSE(report.topologically_certified());
  }
  {
    surface_mesh mesh = sphere;  // collinear corners: zero area
    const auto& t = mesh.triangles[0];
    mesh.positions.push_back(0.25 * mesh.positions[t[0]] + 0.75 * mesh.positions[t[1]]);
    mesh.triangles.push_back({t[0], t[1], static_cast<std::uint32_t>(mesh.positions.size() - 1)});
    EXPECT_EQ(analyze_mesh(mesh).degenerate_triangles, 1u);
  }
  {
    surface_mesh mesh = sphere;  // an edge of 1e-12 Å
    const auto& t = mesh.triangles[0];
    mesh.positions.push_back(mesh.positions[t[0]] + vec3{1e-12, 0, 0});
    mesh.triangles.push_back({t[0], t[1], static_cast<std::uint32_t>(mesh.positions.size() - 1)});
    EXPECT_EQ(analyze_mesh(mesh).degenerate_triangles, 1u);
  }
  {
    surface_mesh mesh = sphere;  // a corner that is not a number
    mesh.positions[0].y = std::nan("");
    const mesh_report report = analyze_mesh(mesh);
    EXPECT_EQ(report.degenerate_triangles, 5u);  // the five triangles around vertex 0
    EXPECT_TRUE(std::isfinite(report.area));
    EXPECT_TRUE(std::isfinite(report.quality.median_edge));
  }
}

TEST(MeshAnalysis, OutOfRangeIndicesAreInvalidNotFatal) {
  surface_mesh mesh = icosphere(1);
  mesh.triangles.push_back({0, 1, 100000});
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_EQ(report.invalid_triangles, 1u);
  EXPECT_EQ(report.degenerate_triangles, 0u);
  EXPECT_EQ(report.boundary_edges, 0u);
  EXPECT_FALSE(report.topologically_certified());
  EXPECT_EQ(count_self_intersections(mesh), 0u);
}

TEST(MeshAnalysis, UnreferencedVertexIsCounted) {
  surface_mesh mesh = icosphere(1);
  mesh.positions.push_back({5, 5, 5});
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_EQ(report.unreferenced_vertices, 1u);
  EXPECT_EQ(report.components.size(), 1u);
  EXPECT_EQ(report.euler_characteristic, 2);  // χ counts the vertices of components only
  EXPECT_FALSE(report.topologically_certified());
}

TEST(MeshAnalysis, SurvivesGarbage) {
  // Random indices (some out of range, some repeated), non-finite and huge coordinates, duplicated faces: the
  // analysis must neither crash nor lose its invariants.
  std::mt19937_64 random(99);
  const double special[] = {std::nan(""), std::numeric_limits<double>::infinity(), 1e29, -1e29, 1e31, 0.0, -0.0};
  for (int round = 0; round < 20; ++round) {
    surface_mesh mesh;
    const std::size_t vertex_count = 1 + random() % 40;
    for (std::size_t v = 0; v < vertex_count; ++v) {
      vec3 p{double(random() % 5), double(random() % 5), double(random() % 5)};
      if (random() % 8 == 0) p[static_cast<int>(random() % 3)] = special[random() % std::size(special)];
      mesh.positions.push_back(p);
    }
    for (std::size_t t = 0; t < 60; ++t) {
      const auto index = [&] { return static_cast<std::uint32_t>(random() % (vertex_count + 2)); };
      mesh.triangles.push_back({index(), index(), index()});
      if (random() % 10 == 0) mesh.triangles.push_back(mesh.triangles.back());
    }
    if (round % 2 == 0) set_radial_normals(mesh, {});
    const mesh_report report = analyze_mesh(mesh);
    EXPECT_EQ(report.triangles, mesh.triangles.size());
    EXPECT_LE(report.invalid_triangles + report.degenerate_triangles, report.triangles);
    EXPECT_LE(report.unreferenced_vertices, report.vertices);
    EXPECT_TRUE(std::isfinite(report.area)) << "round " << round;
    EXPECT_EQ(report.self_intersections, count_self_intersections(mesh));
    std::size_t component_triangles = 0;
    for (const component_report& c : report.components) component_triangles += c.triangles;
    EXPECT_LE(component_triangles, report.triangles);
  }
}

TEST(MeshAnalysis, EmptyMeshGivesEmptyReport) {
  const mesh_report report = analyze_mesh(surface_mesh{});
  EXPECT_EQ(report.triangles, 0u);
  EXPECT_TRUE(report.components.empty());
  EXPECT_EQ(report.area, 0.0);
  EXPECT_EQ(report.achieved_density, 0.0);
  EXPECT_EQ(report.quality.median_edge, 0.0);
  EXPECT_FALSE(report.topologically_certified());
}

// ---------------------------------------------------------------------------------------------------------------
// Self-intersections

TEST(MeshAnalysis, OverlappingSpheresIntersect) {
  surface_mesh mesh = icosphere(3, 1.0, {0, 0, 0});
  append(mesh, icosphere(3, 1.0, {1.1, 0.05, 0.02}));
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_GT(report.self_intersections, 0u);
  EXPECT_EQ(report.self_intersections, count_intersections_brute_force(mesh));
  EXPECT_EQ(report.self_intersections, count_self_intersections(mesh));
  EXPECT_FALSE(report.topologically_certified());
}

TEST(MeshAnalysis, GridAgreesWithBruteForceOnRandomSoups) {
  std::mt19937_64 random(12345);
  std::uniform_real_distribution<double> coordinate(0.0, 10.0);
  std::uniform_real_distribution<double> offset(-1.0, 1.0);
  for (int round = 0; round < 4; ++round) {
    surface_mesh mesh;
    for (std::uint32_t t = 0; t < 400; ++t) {
      // Round 3 adds a few triangles spanning the whole box: the grid has to coarsen to fit its entry budget.
      const double size = (round == 3 && t % 100 == 0) ? 12.0 : 0.3 + 0.4 * round;
      const vec3 base{coordinate(random), coordinate(random), coordinate(random)};
      for (int k = 0; k < 3; ++k) {
        mesh.positions.push_back(base + size * vec3{offset(random), offset(random), offset(random)});
      }
      mesh.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
    }
    const std::size_t expected = count_intersections_brute_force(mesh);
    EXPECT_GT(expected, 0u) << "round " << round;
    EXPECT_EQ(count_self_intersections(mesh), expected) << "round " << round;
  }
}

TEST(MeshAnalysis, CrumpledSphereAgreesWithBruteForce) {
  // Random displacements of about an edge length fold many fans: adjacent pairs go through the per-fan test,
  // separate pairs through the grid; the total must match the all-pairs loop.
  std::mt19937_64 random(7);
  std::normal_distribution<double> noise(0.0, 0.08);
  for (int round = 0; round < 3; ++round) {
    surface_mesh mesh = icosphere(3);
    for (vec3& p : mesh.positions) p += vec3{noise(random), noise(random), noise(random)} * (round + 1.0);
    const std::size_t expected = count_intersections_brute_force(mesh);
    EXPECT_GT(expected, 0u) << "round " << round;
    EXPECT_EQ(count_self_intersections(mesh), expected) << "round " << round;
  }
}

TEST(MeshAnalysis, FanCertificateAcceptsStarsOnly) {
  // Vertex 0 at the origin, a ring of neighbours 1..n around it at height `rise(k)`, triangles (0, k, k + 1).
  const auto fan = [](int turns, int per_turn, double pitch) {
    surface_mesh mesh;
    mesh.positions.push_back({0, 0, 0});
    const int n = turns * per_turn;
    for (int k = 0; k < n; ++k) {
      const double angle = 2 * pi * k / per_turn;
      mesh.positions.push_back({std::cos(angle), std::sin(angle), pitch * k - 0.3});
    }
    for (int k = 0; k < n; ++k) {
      mesh.triangles.push_back({0, static_cast<std::uint32_t>(1 + k), static_cast<std::uint32_t>(1 + (k + 1) % n)});
    }
    return mesh;
  };
  const auto certified = [](const surface_mesh& mesh) {
    const auto defects = detail::classify_triangles(mesh);
    const detail::vertex_fans fans = detail::build_vertex_fans(mesh, defects);
    return detail::fan_is_embedded_star(mesh, defects, 0, fans.around(0));
  };
  EXPECT_TRUE(certified(fan(1, 7, 0.0)));       // a flat disk: projects one-to-one
  EXPECT_TRUE(certified(fan(1, 7, 0.05)));      // a twisted cone: still one turn
  const surface_mesh spiral = fan(2, 7, 0.05);  // two turns: a screw, winding 2
  EXPECT_FALSE(certified(spiral));
  EXPECT_EQ(count_self_intersections(spiral), count_intersections_brute_force(spiral));
  EXPECT_GT(count_self_intersections(spiral), 0u);  // the last triangle closes the screw through the first turn

  EXPECT_TRUE(certified(fan(1, 40, 0.01)));  // large fans take the sorted path of the cycle check
  EXPECT_FALSE(certified(fan(2, 20, 0.01)));
  const mesh_report large = analyze_mesh(fan(1, 40, 0.01));
  EXPECT_EQ(large.non_manifold_vertices, 0u);
  EXPECT_EQ(large.boundary_edges, 40u);

  surface_mesh flipped = fan(1, 7, 0.0);
  std::swap(flipped.triangles[3][1], flipped.triangles[3][2]);
  EXPECT_FALSE(certified(flipped));  // not one consistently oriented cycle
  surface_mesh open = fan(1, 7, 0.0);
  open.triangles.pop_back();
  EXPECT_FALSE(certified(open));  // a boundary vertex
}

TEST(MeshAnalysis, TrianglePairsWithoutSharedVertices) {
  const std::array<vec3, 3> base = {vec3{0, 0, 0}, vec3{4, 0, 0}, vec3{0, 4, 0}};
  // Piercing through the interior.
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{1, 1, -1}, vec3{1, 1, 1}, vec3{2, 1, 1}})), 1u);
  // Above the plane, not touching.
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{1, 1, 0.5}, vec3{2, 1, 1}, vec3{1, 2, 1}})), 0u);
  // A corner exactly on the face (touching counts).
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{1, 1, 0}, vec3{2, 1, 1}, vec3{1, 2, 1}})), 1u);
  // Crossing the plane outside the triangle (beyond the hypotenuse).
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{3, 3, -1}, vec3{3, 3, 1}, vec3{4, 3, 1}})), 0u);
  // Coplanar: overlapping, disjoint, touching along an edge.
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{1, 1, 0}, vec3{5, 1, 0}, vec3{1, 5, 0}})), 1u);
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{3, 3, 0}, vec3{6, 3, 0}, vec3{3, 6, 0}})), 0u);
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{0, 0, 0}, vec3{0, -4, 0}, vec3{4, 0, 0}})), 1u);
  // Near miss: 1e-12 Å above a corner of the other face.
  EXPECT_EQ(count_self_intersections(two_triangles(base, {vec3{1, 1, 1e-12}, vec3{2, 1, 1}, vec3{1, 2, 1}})), 0u);
}

TEST(MeshAnalysis, TrianglePairsSharingOneVertex) {
  // The first triangle (0, 1, 2) lies in z = 0; the second (0, 3, 4) shares vertex 0 at the origin.
  surface_mesh mesh;
  mesh.positions = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {}, {}};
  mesh.triangles = {{0, 1, 2}, {0, 3, 4}};
  const auto count_with = [&](const vec3& third, const vec3& fourth) {
    mesh.positions[3] = third;
    mesh.positions[4] = fourth;
    return count_self_intersections(mesh);
  };
  EXPECT_EQ(count_with({1, 1, 1}, {1, 1, -1}), 1u);     // crosses the interior along x = y
  EXPECT_EQ(count_with({1, 1, 1}, {1, 1, 2}), 0u);      // above: only the shared vertex is common
  EXPECT_EQ(count_with({1, 0, 1}, {0, 1, 1}), 0u);      // above, leaning over the first one
  EXPECT_EQ(count_with({-1, -2, 0}, {-2, -1, 0}), 0u);  // coplanar, in the opposite sector
  EXPECT_EQ(count_with({1, 3, 0}, {3, 1, 0}), 1u);      // coplanar, overlapping sectors
  EXPECT_EQ(count_with({2, 0, 0}, {2, -2, 0}), 1u);     // coplanar, sharing a piece of the edge along +x
  EXPECT_EQ(count_with({2, 0, 1}, {2, 0, -1}), 1u);     // crossing exactly along that edge
}

TEST(MeshAnalysis, TrianglePairsSharingAnEdge) {
  surface_mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}};
  mesh.triangles = {{0, 1, 2}, {1, 0, 3}};
  EXPECT_EQ(count_self_intersections(mesh), 0u);  // flat, on opposite sides of the edge
  mesh.positions[3] = {0.5, 1, 0.5};
  EXPECT_EQ(count_self_intersections(mesh), 0u);  // bent: planes meet only along the edge
  mesh.positions[3] = {0.2, 2, 0};
  EXPECT_EQ(count_self_intersections(mesh), 1u);  // folded flat onto the first triangle
  mesh.triangles[1] = {0, 1, 2};
  EXPECT_EQ(count_self_intersections(mesh), 1u);  // a duplicated face
}

// ---------------------------------------------------------------------------------------------------------------
// Quality

TEST(MeshAnalysis, QualityOfKnownTriangles) {
  surface_mesh mesh;
  const double h = std::sqrt(3.0) / 2;
  mesh.positions = {{0, 0, 0}, {1, 0, 0},  {0.5, h, 0},  // equilateral, edge 1
                    {5, 0, 0}, {7, 0, 0},  {5, 2, 0},    // right isosceles, legs 2
                    {0, 9, 0}, {10, 9, 0}, {0, 10, 0}};  // sliver: legs 10 and 1
  mesh.triangles = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}};
  const quality_report q = analyze_mesh(mesh).quality;
  const double isosceles_ratio = 1 / std::sqrt(2.0), sliver_ratio = 1 / std::sqrt(101.0);
  EXPECT_NEAR(q.edge_ratio_mean, (1 + isosceles_ratio + sliver_ratio) / 3, 1e-12);
  EXPECT_NEAR(q.edge_ratio_min, sliver_ratio, 1e-12);
  const std::array<std::size_t, 10> histogram = {1, 0, 0, 0, 0, 0, 0, 1, 0, 1};
  EXPECT_EQ(q.edge_ratio_histogram, histogram);
  EXPECT_NEAR(q.fraction_below_0_2, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(q.min_angle_deg, std::atan(0.1) * 180 / pi, 1e-9);
  EXPECT_NEAR(q.shortest_edge, 1.0, 1e-12);
  EXPECT_NEAR(q.longest_edge, std::sqrt(101.0), 1e-12);
  // Nine edges: 1 1 1 1 2 2 2√2 10 √101 → the fifth is 2.
  EXPECT_NEAR(q.median_edge, 2.0, 1e-12);
}

TEST(MeshAnalysis, QualityOfAnEquilateralMesh) {
  const mesh_report report = analyze_mesh(icosphere(0, 2.0));  // the icosahedron: 20 equilateral faces
  const quality_report& q = report.quality;
  EXPECT_NEAR(q.edge_ratio_mean, 1.0, 1e-12);
  EXPECT_NEAR(q.edge_ratio_min, 1.0, 1e-12);
  EXPECT_EQ(q.edge_ratio_histogram[9], 20u);
  EXPECT_EQ(q.fraction_below_0_2, 0.0);
  EXPECT_NEAR(q.min_angle_deg, 60.0, 1e-9);
  const double edge = 2.0 / std::sin(2 * pi / 5);  // icosahedron edge for circumradius 2
  EXPECT_NEAR(q.shortest_edge, edge, 1e-12);
  EXPECT_NEAR(q.median_edge, edge, 1e-12);
  EXPECT_NEAR(q.longest_edge, edge, 1e-12);
}

TEST(MeshAnalysis, MedianOfAnEvenEdgeCountIsTheMeanOfTheMiddleTwo) {
  surface_mesh mesh;  // two triangles sharing an edge: five edges, then a third apart: eight edges
  mesh.positions = {{0, 0, 0}, {3, 0, 0}, {0, 4, 0}, {3, 4, 0}, {10, 0, 0}, {11, 0, 0}, {10, 1, 0}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}, {4, 5, 6}};
  // Lengths: 3 4 5 4 3 | 1 1 √2 → sorted 1 1 √2 3 3 4 4 5 → median (3 + 3) / 2.
  EXPECT_NEAR(analyze_mesh(mesh).quality.median_edge, 3.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------------------------
// Determinism and exactness

TEST(MeshAnalysis, ReportDoesNotDependOnThreadCount) {
  surface_mesh mesh = icosphere(5, 1.7, {0.3, 0.1, -0.2});
  append(mesh, icosphere(4, 1.0, {1.5, 0, 0}));
  set_radial_normals(mesh, {});
  mesh_report one, two;
  tbb::task_arena(1).execute([&] { one = analyze_mesh(mesh); });
  tbb::task_arena(2).execute([&] { two = analyze_mesh(mesh); });
  EXPECT_EQ(one.area, two.area);  // bitwise
  EXPECT_EQ(one.volume, two.volume);
  EXPECT_EQ(one.quality.edge_ratio_mean, two.quality.edge_ratio_mean);
  EXPECT_EQ(one.quality.median_edge, two.quality.median_edge);
  EXPECT_EQ(one.self_intersections, two.self_intersections);
  ASSERT_EQ(one.components.size(), two.components.size());
  for (std::size_t c = 0; c < one.components.size(); ++c) EXPECT_EQ(one.components[c].volume, two.components[c].volume);
}

TEST(AnalysisPredicates, Orient2dIsExactNearALine) {
  // a = (0.5 + i·2⁻⁵³, 0.5 + j·2⁻⁵³) against the line through (12, 12) and (24, 24): the exact determinant is
  // 12·(j − i)·2⁻⁵³, far below the rounding error of a plain evaluation.
  const double ulp = std::ldexp(1.0, -53);
  for (int i = 0; i < 16; ++i) {
    for (int j = 0; j < 16; ++j) {
      const int expected = (j > i) - (j < i);
      EXPECT_EQ(detail::orient2d(0.5 + i * ulp, 0.5 + j * ulp, 12, 12, 24, 24), expected) << i << " " << j;
    }
  }
}

TEST(AnalysisPredicates, Orient3dIsExactNearAPlane) {
  // The plane z = x + y through three points with large coordinates; p = (0.5 + i·u, 0.5 + j·u, 1 + 2k·u) is above
  // (z > x + y) exactly when 2k > i + j.
  const vec3 a{12, 0, 12}, b{0, 17, 17}, c{-31, 5, -26};
  const int above = detail::orient3d(a, b, c, {0, 0, 1});
  ASSERT_NE(above, 0);
  const double ulp = std::ldexp(1.0, -53);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      for (int k = 0; k < 8; ++k) {
        const vec3 p{0.5 + i * ulp, 0.5 + j * ulp, 1 + 2 * k * ulp};
        const int expected = above * ((2 * k > i + j) - (2 * k < i + j));
        EXPECT_EQ(detail::orient3d(a, b, c, p), expected) << i << " " << j << " " << k;
      }
    }
  }
}

TEST(AnalysisPredicates, Orient3dSignFollowsPermutations) {
  const vec3 a{0.5, 1, 1.5}, b{2.5, -1, 3.5}, c{-0.3, 2.2, 0.1}, p{0.4, 0.5, 1.3};
  const int s = detail::orient3d(a, b, c, p);
  ASSERT_NE(s, 0);
  EXPECT_EQ(detail::orient3d(b, c, a, p), s);
  EXPECT_EQ(detail::orient3d(c, a, b, p), s);
  EXPECT_EQ(detail::orient3d(b, a, c, p), -s);
  EXPECT_EQ(detail::orient3d(a, c, b, p), -s);
  EXPECT_EQ(detail::orient3d(a, b, c, {1.5, 0, 2.5}), 0);  // the midpoint of ab, exact in binary
}

// ---------------------------------------------------------------------------------------------------------------
// Performance probe (not part of the suite): --gtest_also_run_disabled_tests --gtest_filter=*Probe*

}  // namespace
}  // namespace tracemesh
