#include "core/field/band_culling.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>

#include "core/lattice/lattice_sampler.hpp"

namespace tracemesh {
namespace {

molecule random_cluster(std::size_t count, unsigned seed, double spread) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coord(-spread, spread), radius(1.0, 2.0);
  molecule mol;
  for (std::size_t n = 0; n < count; ++n) mol.atoms.push_back({{coord(rng), coord(rng), coord(rng)}, radius(rng), 0});
  return mol;
}

TEST(band_culling, bounds_enclose_sampled_values) {
  const molecule mol = random_cluster(150, 4, 7);
  const gaussian_field field(mol, -1, 1);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> corner(-12, 10), size(0.3, 4);
  for (int n = 0; n < 100; ++n) {
    const vec3 lo{corner(rng), corner(rng), corner(rng)};
    const double s = size(rng);
    const box3 box{lo, lo + vec3{s, s, s}};
    std::vector<std::uint32_t> atoms;
    field.atoms_near_box(box, atoms);
    const field_bounds bounds = bound_field_on_box(field, box, atoms);
    for (int m = 0; m < 50; ++m) {
      std::uniform_real_distribution<double> u(0, s);
      const double phi = field.value(lo + vec3{u(rng), u(rng), u(rng)});
      EXPECT_GE(phi, bounds.lower * (1 - 1e-12));
      EXPECT_LE(phi, bounds.upper * (1 + 1e-12));
    }
  }
}

// The bounds are eq. 4–5 exactly: the product over the axes of each atom's 1-D kernel extremes on the box (computed
// here with std::exp, per axis, as the paper writes it).
TEST(band_culling, bounds_are_the_per_axis_products_of_kernel_extremes) {
  const molecule mol = random_cluster(120, 5, 6);
  const gaussian_field field(mol, -1.3, 1);
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> corner(-9, 7), size(0.2, 5);
  for (int n = 0; n < 100; ++n) {
    const vec3 lo{corner(rng), corner(rng), corner(rng)};
    const box3 box{lo, lo + vec3{size(rng), size(rng), size(rng)}};
    std::vector<std::uint32_t> atoms;
    field.atoms_near_box(box, atoms);
    field_bounds expected;
    for (const std::uint32_t k : atoms) {
      const auto a = field.atom_at(k);
      const vec3 c{a.x, a.y, a.z};
      double upper = std::exp(-field.d()), lower = std::exp(-field.d()), near2 = 0, far2 = 0;
      for (int axis = 0; axis < 3; ++axis) {
        const double to_lo = box.lo[axis] - c[axis], to_hi = box.hi[axis] - c[axis];
        const double near = (to_lo <= 0 && to_hi >= 0) ? 0.0 : std::min(std::abs(to_lo), std::abs(to_hi));
        const double far = std::max(std::abs(to_lo), std::abs(to_hi));
        upper *= std::exp(field.d() * near * near * a.inv_r2);
        lower *= std::exp(field.d() * far * far * a.inv_r2);
        near2 += near * near;
        far2 += far * far;
      }
      if (near2 < a.cutoff2) expected.upper += upper;
      if (far2 < a.cutoff2) expected.lower += lower;
    }
    const field_bounds bounds = bound_field_on_box(field, box, atoms);
    EXPECT_NEAR(bounds.upper, expected.upper, 1e-12 * (1 + expected.upper));
    EXPECT_NEAR(bounds.lower, expected.lower, 1e-12 * (1 + expected.lower));
  }
}

// Property: a block dropped by the culling never holds a sign change, on a lattice 4× finer than the mesher's.
TEST(band_culling, never_drops_a_block_that_holds_surface) {
  const molecule mol = random_cluster(40, 21, 6);
  const gaussian_field field(mol, -1, 1);
  const lattice lat(1.0, {-64, -64, -64});
  progress_token progress;
  auto kept = cull_blocks(field, lat, progress);
  ASSERT_TRUE(kept.ok());
  ASSERT_FALSE(kept->empty());
  const auto is_kept = [&](const lattice_index& b) {
    return std::binary_search(kept->begin(), kept->end(), b, [](const lattice_index& a, const lattice_index& c) {
      return std::tie(a.i, a.j, a.k) < std::tie(c.i, c.j, c.k);
    });
  };
  std::size_t dropped_checked = 0;
  for (std::int64_t bi = -3; bi <= 2; ++bi) {
    for (std::int64_t bj = -3; bj <= 2; ++bj) {
      for (std::int64_t bk = -3; bk <= 2; ++bk) {
        if (is_kept({bi, bj, bk})) continue;
        ++dropped_checked;
        const box3 box = lat.block_box({bi, bj, bk});
        const bool inside = field.value(box.lo) >= 1.0;
        constexpr int n = 4 * lattice::block_cells;
        for (int x = 0; x <= n; x += 1) {
          for (int y = 0; y <= n; y += 2) {
            for (int z = 0; z <= n; z += 2) {
              const vec3 p = box.lo + vec3{x * 0.25, y * 0.25, z * 0.25};
              ASSERT_EQ(field.value(p) >= 1.0, inside) << "dropped block " << bi << "," << bj << "," << bk;
            }
          }
        }
      }
    }
  }
  EXPECT_GT(dropped_checked, 50u);
}

TEST(band_culling, keeps_blocks_only_near_the_surface) {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, 2.0, 0});
  const gaussian_field field(mol, -1, 1);
  const lattice lat(0.5, {-64, -64, -64});
  progress_token progress;
  auto kept = cull_blocks(field, lat, progress);
  ASSERT_TRUE(kept.ok());
  // A sphere of radius 2 Å on 4 Å blocks: the 2×2×2 blocks around the origin, nothing far away.
  EXPECT_EQ(kept->size(), 8u);
}

TEST(band_culling, cancellation_is_reported) {
  const molecule mol = random_cluster(40, 2, 6);
  const gaussian_field field(mol, -1, 1);
  const lattice lat(1.0, {-64, -64, -64});
  progress_token progress;
  progress.cancel();
  auto kept = cull_blocks(field, lat, progress);
  ASSERT_FALSE(kept.ok());
  EXPECT_EQ(kept.error().code(), errc::cancelled);
}

}  // namespace
}  // namespace tracemesh
