#include "core/lattice/edge_root.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/lattice/lattice_sampler.hpp"

namespace tracemesh {
namespace {

// Roots agree with dense sampling: every cut edge has its root where dense samples change sign, and the root is on
// the surface to far better than the certificate's 1e-3 Å.
TEST(edge_root, roots_agree_with_dense_sampling) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coord(-4, 4), radius(1.0, 2.0);
  molecule mol;
  for (int n = 0; n < 30; ++n) mol.atoms.push_back({{coord(rng), coord(rng), coord(rng)}, radius(rng), 0});
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.9, {-64, -64, -64});
  std::size_t roots_checked = 0;
  for (const lattice_index& block : {lattice_index{-1, -1, -1}, lattice_index{0, 0, 0}, lattice_index{-1, 0, 0}}) {
    std::vector<std::uint32_t> atoms;
    field.atoms_near_box(lat.block_box(block), atoms);
    std::vector<double> values;
    sample_block(field, lat, block, atoms, values);
    std::vector<edge_vertex> roots;
    solve_block_roots(field, lat, block, atoms, values, roots);
    for (const edge_vertex& root : roots) {
      const auto ends = lat.edge_ends(root.key);
      const vec3 a = lat.point(ends[0]), b = lat.point(ends[1]);
      EXPECT_LT(field.surface_distance(root.position), 1e-6);
      // Dense sampling along the edge: the sign must differ on the two sides of the root.
      const double t = norm(root.position - a) / norm(b - a);
      const double eps = 1e-3;
      if (t > 2 * eps && t < 1 - 2 * eps) {
        const bool before = field.value(a + (b - a) * (t - eps)) >= 1.0;
        const bool after = field.value(a + (b - a) * (t + eps)) >= 1.0;
        EXPECT_NE(before, after);
      }
      // And it is the edge's only sign change at the sampled resolution, seen from the end points.
      EXPECT_NE(field.value(a) >= 1.0, field.value(b) >= 1.0);
      ++roots_checked;
    }
  }
  EXPECT_GT(roots_checked, 100u);
}

// One atom: φ = t0 is the sphere of radius r (d = −1, t0 = 1), so every root lies on it to rounding, whatever the
// edge direction and however far the linear interpolation of the end values is from it.
TEST(edge_root, roots_on_a_single_atom_lie_on_its_sphere) {
  molecule mol;
  const vec3 centre{0.31, -0.17, 0.23};
  const double r = 1.8;
  mol.atoms.push_back({centre, r, 0});
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.7, {-64, -64, -64});
  std::size_t roots_checked = 0;
  std::vector<int> per_direction(7, 0);
  for (std::int64_t bi = -1; bi <= 0; ++bi) {
    for (std::int64_t bj = -1; bj <= 0; ++bj) {
      for (std::int64_t bk = -1; bk <= 0; ++bk) {
        const lattice_index block{bi, bj, bk};
        std::vector<std::uint32_t> atoms;
        field.atoms_near_box(lat.block_box(block), atoms);
        std::vector<double> values;
        sample_block(field, lat, block, atoms, values);
        std::vector<edge_vertex> roots;
        solve_block_roots(field, lat, block, atoms, values, roots);
        for (const edge_vertex& root : roots) {
          EXPECT_NEAR(norm(root.position - centre), r, 1e-12);
          ++per_direction[root.key & 7];
          ++roots_checked;
        }
      }
    }
  }
  EXPECT_GT(roots_checked, 300u);
  for (int direction = 0; direction < 7; ++direction) EXPECT_GT(per_direction[direction], 0) << direction;
}

// Solving a block twice gives the same roots, bit for bit, in the same order.
TEST(edge_root, roots_are_reproducible) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> coord(-4, 4), radius(1.0, 2.0);
  molecule mol;
  for (int n = 0; n < 40; ++n) mol.atoms.push_back({{coord(rng), coord(rng), coord(rng)}, radius(rng), 0});
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.8, {-64, -64, -64});
  std::vector<std::uint32_t> atoms;
  field.atoms_near_box(lat.block_box({0, -1, 0}), atoms);
  std::vector<double> values;
  sample_block(field, lat, {0, -1, 0}, atoms, values);
  std::vector<edge_vertex> first, second;
  solve_block_roots(field, lat, {0, -1, 0}, atoms, values, first);
  solve_block_roots(field, lat, {0, -1, 0}, atoms, values, second);
  ASSERT_FALSE(first.empty());
  ASSERT_EQ(first.size(), second.size());
  for (std::size_t n = 0; n < first.size(); ++n) {
    EXPECT_EQ(first[n].key, second[n].key);
    EXPECT_EQ(first[n].position, second[n].position);
  }
}

}  // namespace
}  // namespace tracemesh
