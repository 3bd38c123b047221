// Tests of core/analysis/analysis_local_folds.hpp through the report (mesh_report::folded_triangles,
// near_duplicate_vertex_pairs): hand-made meshes whose folds and near-coincident vertices are known.
#include "core/analysis/analysis_local_folds.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <random>
#include <utility>

#include "core/analysis/mesh_analysis.hpp"
#include "support/analysis_meshes.hpp"

namespace tracemesh {
namespace {

using testing::append;
using testing::icosphere;
using testing::set_radial_normals;
using testing::tetrahedron;

/// A regular-ish tetrahedron around the origin with outward faces and radial normals.
surface_mesh tetrahedron_with_normals() {
  surface_mesh mesh = tetrahedron({1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1});
  set_radial_normals(mesh, {});
  return mesh;
}

TEST(LocalFolds, TetrahedronWithOneFaceFlippedHasOneFold) {
  surface_mesh mesh = tetrahedron_with_normals();
  EXPECT_EQ(analyze_mesh(mesh).folded_triangles, 0u);
  std::swap(mesh.triangles[2][1], mesh.triangles[2][2]);
  EXPECT_EQ(analyze_mesh(mesh).folded_triangles, 1u);
}

TEST(LocalFolds, AFoldInAnOrientedManifoldIsCounted) {
  // Orientation, manifoldness and intersections all pass: only the normals at one triangle's corners say that the
  // surface faces the other way there (the mesher's certificate then fails a trace mesh: mesher_test.cpp).
  surface_mesh mesh = icosphere(2);
  set_radial_normals(mesh, {});
  for (const std::uint32_t v : mesh.triangles[7]) mesh.normals[v] = -1.0 * mesh.normals[v];
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_EQ(report.inconsistently_oriented_edges, 0u);
  EXPECT_EQ(report.self_intersections, 0u);
  EXPECT_EQ(report.inward_oriented_components, 0u);
  EXPECT_EQ(report.folded_triangles, 1u);
}

TEST(LocalFolds, ATriangleAgainstOnlySomeOfItsCornersIsNoFold) {
  // One reversed vertex normal: each of its triangles still agrees with the two other corners.
  surface_mesh mesh = icosphere(2);
  set_radial_normals(mesh, {});
  mesh.normals[0] = -1.0 * mesh.normals[0];
  EXPECT_EQ(analyze_mesh(mesh).folded_triangles, 0u);
  // Two reversed corners of one triangle: the triangles holding both fold against two corners only.
  mesh.normals[mesh.triangles[0][1]] = -1.0 * mesh.normals[mesh.triangles[0][1]];
  EXPECT_EQ(analyze_mesh(mesh).folded_triangles, 0u);
}

TEST(LocalFolds, NoNormalsNoFolds) {
  surface_mesh mesh = tetrahedron_with_normals();
  std::swap(mesh.triangles[2][1], mesh.triangles[2][2]);
  mesh.normals.clear();
  EXPECT_EQ(analyze_mesh(mesh).folded_triangles, 0u);
  mesh = tetrahedron_with_normals();
  std::swap(mesh.triangles[2][1], mesh.triangles[2][2]);
  mesh.normals.pop_back();  // not one per vertex: left to inward_oriented_components
  EXPECT_EQ(analyze_mesh(mesh).folded_triangles, 0u);
}

/// Two closed tetrahedra pointing at each other, their tips `gap` Å apart along x (edges about 1.4–1.7 Å).
surface_mesh tetrahedra_tip_to_tip(double gap) {
  surface_mesh mesh = tetrahedron({0, 0, 0}, {-1, 1, 0}, {-1, -0.5, 0.8}, {-1, -0.5, -0.8});
  append(mesh, tetrahedron({gap, 0, 0}, {gap + 1, 1, 0}, {gap + 1, -0.5, 0.8}, {gap + 1, -0.5, -0.8}));
  set_radial_normals(mesh, {-0.75, 0, 0});
  for (std::size_t v = 4; v < 8; ++v) mesh.normals[v] = normalized(mesh.positions[v] - vec3{gap + 0.75, 0, 0});
  return mesh;
}

TEST(LocalFolds, VerticesAHairApartWithoutAnEdgeAreNearDuplicates) {
  const mesh_report close = analyze_mesh(tetrahedra_tip_to_tip(1e-3));
  EXPECT_EQ(close.near_duplicate_vertex_pairs, 1u);
  EXPECT_EQ(close.self_intersections, 0u);
  EXPECT_EQ(close.folded_triangles, 0u);
  EXPECT_TRUE(close.topologically_certified());
  // 0.5 Å is over 0.1 × any median edge here: not a near duplicate.
  EXPECT_EQ(analyze_mesh(tetrahedra_tip_to_tip(0.5)).near_duplicate_vertex_pairs, 0u);
}

TEST(LocalFolds, AShortEdgeIsNoNearDuplicate) {
  // The ends of an edge of 1e-3 Å (a sliver tetrahedron) share that edge.
  surface_mesh mesh = tetrahedron({0, 0, 0}, {1e-3, 0, 0}, {0.5, 1, 0}, {0.5, 0.3, 1});
  EXPECT_EQ(analyze_mesh(mesh).near_duplicate_vertex_pairs, 0u);
}

TEST(LocalFolds, NearDuplicatesOfManyPairsAreEachCountedOnce) {
  // Every vertex of a sphere doubled by a copy moved 1e-4 Å: one pair per vertex, however the grid cuts them.
  surface_mesh mesh = icosphere(3, 2.0);
  const std::size_t vertices = mesh.positions.size();
  surface_mesh copy = icosphere(3, 2.0);
  for (vec3& p : copy.positions) p += vec3{1e-4, 0, 0};
  append(mesh, copy);
  std::size_t one = 0, two = 0;
  tbb::task_arena(1).execute([&] { one = analyze_mesh(mesh).near_duplicate_vertex_pairs; });
  tbb::task_arena(2).execute([&] { two = analyze_mesh(mesh).near_duplicate_vertex_pairs; });
  EXPECT_EQ(one, vertices);
  EXPECT_EQ(two, one);
  EXPECT_EQ(analyze_mesh(icosphere(3, 2.0)).near_duplicate_vertex_pairs, 0u);
}

/// Separate unit triangles at scattered places, every second one a copy of the one before moved by `gap` (in a
/// scattered direction): three close pairs per copy. The fixed seed gives the same mesh everywhere.
surface_mesh scattered_triangle_pairs(std::size_t pairs, double gap) {
  std::mt19937 random(20261202);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * (random() / 4294967296.0); };
  surface_mesh mesh;
  const auto add_triangle = [&](const vec3& corner) {
    const auto first = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {corner, corner + vec3{1, 0, 0}, corner + vec3{0.5, 0.8660254, 0}});
    mesh.triangles.push_back({first, first + 1, first + 2});
  };
  for (std::size_t k = 0; k < pairs; ++k) {
    const vec3 corner{uniform(0, 40), uniform(0, 40), uniform(0, 40)};
    add_triangle(corner);
    add_triangle(corner + gap * normalized(vec3{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)}));
  }
  return mesh;
}

/// Pairs of vertices of different triangles closer than near_duplicate_fraction × their (unit) edges.
std::size_t near_pairs_by_brute_force(const surface_mesh& mesh) {
  std::size_t pairs = 0;
  for (std::size_t a = 0; a < mesh.positions.size(); ++a) {
    for (std::size_t b = a + 1; b < mesh.positions.size(); ++b) {
      if (a / 3 != b / 3 && distance(mesh.positions[a], mesh.positions[b]) < near_duplicate_fraction) ++pairs;
    }
  }
  return pairs;
}

TEST(LocalFolds, NearDuplicatesAcrossTheFacesOfTheSearchGridAreFound) {
  // About 3 Å cells over 40 Å: dozens of the 1,200 close pairs straddle a face, edge or corner of a cell.
  for (const double gap : {0.02, 0.06, 0.099}) {
    const surface_mesh mesh = scattered_triangle_pairs(400, gap);
    const std::size_t expected = near_pairs_by_brute_force(mesh);
    EXPECT_GE(expected, 1200u) << gap;
    EXPECT_EQ(analyze_mesh(mesh).near_duplicate_vertex_pairs, expected) << gap;
  }
}

TEST(analysis_local_folds, vertex_pairs_closer_than_lists_each_close_pair_once_across_cells) {
  surface_mesh m;
  // 0 and 1 straddle a cell face (cells 0.1 wide); 2 is 0.11 from 1; 3 is far from all.
  m.positions = {{0.099, 0, 0}, {0.101, 0.05, 0}, {0.101, 0.16, 0}, {5, 5, 5}, {0.12, 0.05, 0.02}};
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> expected{{0, 1}, {0, 4}, {1, 4}};
  EXPECT_EQ(detail::vertex_pairs_closer_than(m, 0.1), expected);
}

}  // namespace
}  // namespace tracemesh
