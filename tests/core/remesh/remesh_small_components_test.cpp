// Small components made again (core/remesh/remesh_small_components.hpp) on fields whose surfaces are known: one
// atom's sphere (a blob) and the void at the centre of an octahedron of atoms (a cavity), each first meshed as a
// sliver tetrahedron whose corners are found here by bisection along rays.
#include "core/remesh/remesh_small_components.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "core/remesh/remesh_geometry.hpp"
#include "support/mesh_expectations.hpp"

namespace tracemesh {
namespace {

using triangle = std::array<std::uint32_t, 3>;

/// The point of {φ = t0} on the ray from `centre` along unit `u`, by bisection on [0, reach] (φ − t0 changes sign
/// once there for the fields below).
vec3 surface_on_ray(const gaussian_field& field, const vec3& centre, const vec3& u, double reach) {
  const bool inside_below = field.value(centre) < field.t0();
  double lo = 0, hi = reach;
  for (int i = 0; i < 200; ++i) {
    const double mid = (lo + hi) / 2;
    ((field.value(centre + u * mid) < field.t0()) == inside_below ? lo : hi) = mid;
  }
  return centre + u * lo;
}

/// A sliver tetrahedron of the surface around `centre`: three corners close together about +z and one at −z,
/// outward (against ∇φ) for a blob, towards the centre for a cavity; field normals filled.
surface_mesh sliver_tetrahedron(const gaussian_field& field, const vec3& centre, double reach) {
  const std::array<vec3, 4> directions{normalized(vec3{0.12, 0, 1}), normalized(vec3{-0.06, 0.104, 1}),
                                       normalized(vec3{-0.06, -0.104, 1}), vec3{0, 0, -1}};
  surface_mesh m;
  for (const vec3& u : directions) {
    m.positions.push_back(surface_on_ray(field, centre, u, reach));
    m.normals.push_back(detail::field_normal(field, m.positions.back()));
  }
  m.triangles = {triangle{0, 1, 2}, triangle{0, 3, 1}, triangle{1, 3, 2}, triangle{2, 3, 0}};  // outward from centre
  if (field.value(centre) < field.t0()) {
    for (triangle& t : m.triangles) std::swap(t[1], t[2]);
  }
  return m;
}

double worst_quality(const surface_mesh& m) {
  double worst = 1;
  for (const triangle& t : m.triangles) {
    worst = std::min(worst, detail::triangle_quality(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]));
  }
  return worst;
}

double shortest_edge(const surface_mesh& m) {
  double shortest = 1e300;
  for (const triangle& t : m.triangles) {
    for (int i = 0; i < 3; ++i) shortest = std::min(shortest, distance(m.positions[t[i]], m.positions[t[(i + 1) % 3]]));
  }
  return shortest;
}

/// Every vertex on {φ = t0} (first-order distance) and with its field normal.
void expect_on_surface_with_normals(const gaussian_field& field, const surface_mesh& m) {
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (std::size_t v = 0; v < m.positions.size(); ++v) {
    EXPECT_LT(field.surface_distance(m.positions[v]), 1e-9) << "vertex " << v;
    EXPECT_NEAR(dot(m.normals[v], detail::field_normal(field, m.positions[v])), 1.0, 1e-9) << "vertex " << v;
  }
}

double max_x(const std::vector<vec3>& points) {
  double x = -1e300;
  for (const vec3& p : points) x = std::max(x, p.x);
  return x;
}

/// Adds a large tetrahedron (6 Å across, never small) with a face in the plane x = `wall` covering y, z in [−3, 3]
/// about the axis, and its fourth corner at x = 5.
void add_wall_tetrahedron(surface_mesh& m, double wall) {
  const auto base = static_cast<std::uint32_t>(m.positions.size());
  for (const vec3& p : {vec3{wall, -3, -3}, vec3{wall, 3, -3}, vec3{wall, 0, 3}, vec3{5, 0, 0}}) {
    m.positions.push_back(p);
    m.normals.push_back(normalized(p - vec3{1.5, 0, 0}));
  }
  // Outward seen from its inside (x > wall): the face in the plane faces −x.
  m.triangles.push_back({base, base + 2, base + 1});
  m.triangles.push_back({base, base + 1, base + 3});
  m.triangles.push_back({base + 1, base + 2, base + 3});
  m.triangles.push_back({base + 2, base, base + 3});
}

/// Six atoms of radius r at ±1.7 r on the axes: φ(0) = 6·e^(−1.89) ≈ 0.91 < 1, and the gaps between them are
/// closed (φ ≈ 1.19 at the centres of the octahedron's faces), so a small void surrounds the origin.
molecule octahedral_void(double r) {
  molecule mol;
  const double a = 1.7 * r;
  for (const vec3& axis : {vec3{1, 0, 0}, vec3{0, 1, 0}, vec3{0, 0, 1}}) {
    mol.atoms.push_back({axis * a, r, 0});
    mol.atoms.push_back({axis * -a, r, 0});
  }
  return mol;
}

TEST(remesh_small_components, a_sliver_tetrahedron_of_a_small_sphere_is_made_regular) {
  const gaussian_field field(molecule{{atom{{0.2, -0.1, 0.3}, 0.5, 0}}, 0}, -1, 1);
  surface_mesh m = sliver_tetrahedron(field, {0.2, -0.1, 0.3}, 2);
  const double before = worst_quality(m);
  ASSERT_LT(before, 0.3);

  EXPECT_EQ(detail::resample_small_components(m, field, 1.0), 1U);

  testing::expect_certified_report(analyze_mesh(m));
  expect_on_surface_with_normals(field, m);
  EXPECT_EQ(m.positions.size(), 4U);  // a sphere of π/4 Å² asks for fewer vertices than 4 (one per 2 triangles of L)
  // The sliver's shortest edge is 0.06; a regular tetrahedron in this sphere has edges of 0.816 (0.815 here;
  // polishing that stopped once every triangle's quality reached 0.9 left 0.736).
  EXPECT_GT(worst_quality(m), 0.98) << worst_quality(m);
  EXPECT_GT(shortest_edge(m), 0.8) << shortest_edge(m);
}

TEST(remesh_small_components, a_sliver_tetrahedron_of_a_tiny_cavity_is_made_regular_and_faces_into_the_cavity) {
  const gaussian_field field(octahedral_void(1.5), -1, 1);
  ASSERT_LT(field.value({0, 0, 0}), 1.0);
  surface_mesh m = sliver_tetrahedron(field, {0, 0, 0}, 2);
  const double before = worst_quality(m);
  ASSERT_LT(before, 0.3);

  EXPECT_EQ(detail::resample_small_components(m, field, 1.5), 1U);

  testing::expect_certified_report(analyze_mesh(m));
  expect_on_surface_with_normals(field, m);
  EXPECT_GT(worst_quality(m), 0.98) << worst_quality(m);
  EXPECT_GT(shortest_edge(m), 0.83) << shortest_edge(m);  // 0.845; 0.807 when polishing stopped at quality 0.9
  for (const triangle& t : m.triangles) {  // outward from the molecule is into the void, towards its centre
    const vec3 &a = m.positions[t[0]], &b = m.positions[t[1]], &c = m.positions[t[2]];
    EXPECT_LT(dot(detail::area_vector(a, b, c), a + b + c), 0);
  }
}

TEST(remesh_small_components, a_component_wider_than_two_target_edges_is_left_alone) {
  const gaussian_field field(molecule{{atom{{0, 0, 0}, 0.5, 0}}, 0}, -1, 1);
  surface_mesh m = sliver_tetrahedron(field, {0, 0, 0}, 2);
  const surface_mesh before = m;

  EXPECT_EQ(detail::resample_small_components(m, field, 0.4), 0U);  // 2 L = 0.8 < the tetrahedron's 1.0 Å

  EXPECT_EQ(m.positions, before.positions);
  EXPECT_EQ(m.triangles, before.triangles);
}

TEST(remesh_small_components, a_remake_that_would_cut_another_component_is_not_made) {
  // The sliver stays within 0.06 Å of the z axis; any tetrahedron spread over the sphere of radius 0.5 has a corner
  // beyond x = 0.5/3 and one on the other side, so its faces cross the plane x = 0.16, where a large tetrahedron
  // (6 Å across, never small) has a face covering the sphere's section.
  const gaussian_field field(molecule{{atom{{0, 0, 0}, 0.5, 0}}, 0}, -1, 1);
  surface_mesh m = sliver_tetrahedron(field, {0, 0, 0}, 2);
  ASSERT_LT(std::max({m.positions[0].x, m.positions[1].x, m.positions[2].x, m.positions[3].x}), 0.16);
  add_wall_tetrahedron(m, 0.16);
  testing::expect_certified_report(analyze_mesh(m));
  const surface_mesh before = m;

  EXPECT_EQ(detail::resample_small_components(m, field, 1.0), 0U);

  EXPECT_EQ(m.positions, before.positions);
  EXPECT_EQ(m.triangles, before.triangles);
}

TEST(remesh_small_components, a_lengthened_remake_that_would_cut_another_component_falls_back_to_the_polished_one) {
  // A cigar of three atoms along x (1.8 Å long, 0.9 Å wide): polished, its tetrahedron stays within x < 0.5;
  // lengthened, a corner goes out to x = 0.72. A wall at x = 0.6 lets the first through, not the second.
  const gaussian_field field(
      molecule{{atom{{-0.5, 0, 0}, 0.45, 0}, atom{{0, 0, 0}, 0.45, 0}, atom{{0.5, 0, 0}, 0.45, 0}}, 0}, -1, 1);
  const double wall = 0.6, target_edge = 1.3;
  const surface_mesh sliver = sliver_tetrahedron(field, {0, 0, 0}, 2);
  surface_mesh alone = sliver;
  ASSERT_EQ(detail::resample_small_components(alone, field, target_edge), 1U);
  ASSERT_GT(max_x(alone.positions), wall);
  surface_mesh m = sliver;
  add_wall_tetrahedron(m, wall);

  EXPECT_EQ(detail::resample_small_components(m, field, target_edge), 1U);

  testing::expect_certified_report(analyze_mesh(m));
  surface_mesh cigar;  // the remade component: after the wall's 4 vertices and 4 triangles
  cigar.positions.assign(m.positions.begin() + 4, m.positions.end());
  for (auto it = m.triangles.begin() + 4; it != m.triangles.end(); ++it) {
    cigar.triangles.push_back({(*it)[0] - 4, (*it)[1] - 4, (*it)[2] - 4});
  }
  ASSERT_EQ(cigar.positions.size(), 4U);
  EXPECT_LT(max_x(cigar.positions), wall);
  EXPECT_GE(worst_quality(cigar), 0.9);
  EXPECT_GT(shortest_edge(cigar), 0.9);                   // 0.98; the sliver's 0.07
  EXPECT_GT(shortest_edge(alone), shortest_edge(cigar));  // 1.06 lengthened
}

}  // namespace
}  // namespace tracemesh
