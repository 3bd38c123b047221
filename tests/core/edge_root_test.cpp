#include "core/edge_root.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/lattice_sampler.hpp"

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

}  // namespace
}  // namespace tracemesh
