#include "core/lattice/marching_tetrahedra.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>

#include "core/lattice/lattice_sampler.hpp"

namespace tracemesh {
namespace {

constexpr int n = block_points;

/// Values of a synthetic field on one block: a union of balls (inside = value ≥ 1), all well inside the block.
std::vector<double> balls_field(const std::vector<std::pair<vec3, double>>& balls) {
  std::vector<double> values(n * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        double v = 0;
        for (const auto& [c, r] : balls) v = std::max(v, r * r / std::max(1e-9, squared_norm(vec3{1.0 * x, 1.0 * y, 1.0 * z} - c)));
        values[(z * n + y) * n + x] = v;
      }
  return values;
}

std::vector<std::array<std::uint64_t, 3>> triangles_of(const block_polygons& p) {
  std::vector<std::array<std::uint64_t, 3>> tris = p.triangles;
  for (const auto& q : p.quads) {
    tris.push_back({q[0], q[1], q[2]});
    tris.push_back({q[0], q[2], q[3]});
  }
  return tris;
}

vec3 edge_midpoint(const lattice& lat, std::uint64_t key) {
  const auto ends = lat.edge_ends(key);
  return (lat.point(ends[0]) + lat.point(ends[1])) * 0.5;
}

TEST(marching_tetrahedra, surface_is_closed_and_consistently_oriented) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> centre(2.5, 5.5), radius(0.6, 1.8);
  const lattice lat(1.0, {0, 0, 0});
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::pair<vec3, double>> balls;
    for (int b = 0; b < 3; ++b) balls.push_back({{centre(rng), centre(rng), centre(rng)}, radius(rng)});
    block_polygons polygons;
    triangulate_block(lat, {0, 0, 0}, balls_field(balls), 1.0, polygons);
    const auto tris = triangles_of(polygons);
    ASSERT_FALSE(tris.empty());
    std::map<std::pair<std::uint64_t, std::uint64_t>, int> directed;
    for (const auto& t : tris)
      for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
    for (const auto& [edge, count] : directed) {
      EXPECT_EQ(count, 1) << "edge used twice in the same direction";
      EXPECT_EQ(directed.count({edge.second, edge.first}), 1u) << "boundary edge";
    }
    // Outward orientation: positive enclosed volume with vertices at the edge midpoints.
    double volume = 0;
    for (const auto& t : tris) {
      volume += dot(edge_midpoint(lat, t[0]), cross(edge_midpoint(lat, t[1]), edge_midpoint(lat, t[2]))) / 6;
    }
    EXPECT_GT(volume, 0);
  }
}

TEST(marching_tetrahedra, uniform_block_gives_nothing) {
  const lattice lat(1.0, {0, 0, 0});
  block_polygons polygons;
  triangulate_block(lat, {0, 0, 0}, std::vector<double>(n * n * n, 2.0), 1.0, polygons);
  triangulate_block(lat, {0, 0, 0}, std::vector<double>(n * n * n, 0.5), 1.0, polygons);
  EXPECT_TRUE(polygons.triangles.empty());
  EXPECT_TRUE(polygons.quads.empty());
}

TEST(marching_tetrahedra, single_inside_point_gives_a_closed_diamond) {
  const lattice lat(1.0, {0, 0, 0});
  std::vector<double> values(n * n * n, 0.0);
  values[(4 * n + 4) * n + 4] = 2.0;
  block_polygons polygons;
  triangulate_block(lat, {0, 0, 0}, values, 1.0, polygons);
  // A lattice point of the Freudenthal lattice has 14 edges and 24 tetrahedra around it.
  EXPECT_EQ(polygons.triangles.size(), 24u);
  EXPECT_TRUE(polygons.quads.empty());
}

}  // namespace
}  // namespace tracemesh
