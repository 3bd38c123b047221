#include "core/lattice/lattice_sampler.hpp"

#include <gtest/gtest.h>

#include <random>

namespace tracemesh {
namespace {

molecule random_cluster(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coord(-5, 5), radius(1.0, 2.0);
  molecule mol;
  for (std::size_t n = 0; n < count; ++n) mol.atoms.push_back({{coord(rng), coord(rng), coord(rng)}, radius(rng), 0});
  return mol;
}

std::vector<double> sample(const gaussian_field& field, const lattice& lat, const lattice_index& block) {
  std::vector<std::uint32_t> atoms;
  field.atoms_near_box(lat.block_box(block), atoms);
  std::vector<double> values;
  sample_block(field, lat, block, atoms, values);
  return values;
}

TEST(lattice_sampler, matches_pointwise_evaluation) {
  const molecule mol = random_cluster(50, 1);
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.7, {-64, -64, -64});
  const lattice_index block{-1, 0, -1};
  const std::vector<double> values = sample(field, lat, block);
  constexpr int n = block_points;
  for (int z = 0; z < n; ++z) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const lattice_index p{block.i * lattice::block_cells + x, block.j * lattice::block_cells + y,
                              block.k * lattice::block_cells + z};
        const double expected = field.value(lat.point(p));
        EXPECT_NEAR(values[(z * n + y) * n + x], expected, 1e-12 * (1 + expected));
      }
    }
  }
}

// Neighbouring blocks must agree bit for bit on their shared face, or their signs (and meshes) could disagree.
TEST(lattice_sampler, neighbouring_blocks_agree_bitwise_on_shared_faces) {
  const molecule mol = random_cluster(120, 2);
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.6, {-64, -64, -64});
  constexpr int n = block_points;
  for (const lattice_index& block : {lattice_index{-1, -1, -1}, lattice_index{0, -1, 0}, lattice_index{-1, 0, -1}}) {
    const std::vector<double> here = sample(field, lat, block);
    const std::vector<double> right = sample(field, lat, {block.i + 1, block.j, block.k});
    const std::vector<double> behind = sample(field, lat, {block.i, block.j + 1, block.k});
    const std::vector<double> above = sample(field, lat, {block.i, block.j, block.k + 1});
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        EXPECT_EQ(here[(b * n + a) * n + (n - 1)], right[(b * n + a) * n + 0]);  // x faces
        EXPECT_EQ(here[(b * n + (n - 1)) * n + a], behind[(b * n + 0) * n + a]);  // y faces
        EXPECT_EQ(here[((n - 1) * n + b) * n + a], above[(0 * n + b) * n + a]);  // z faces
      }
    }
  }
}

}  // namespace
}  // namespace tracemesh
