#include "core/gaussian_field.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace tracemesh {
namespace {

molecule random_cluster(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coord(-8, 8), radius(1.0, 2.0);
  molecule mol;
  for (std::size_t n = 0; n < count; ++n) mol.atoms.push_back({{coord(rng), coord(rng), coord(rng)}, radius(rng), 0});
  return mol;
}

double brute_force_phi(const molecule& mol, const vec3& p, double d) {
  double phi = 0;
  for (const atom& a : mol.atoms) {
    if (a.radius > 0) phi += std::exp(d * (squared_norm(p - a.center) / (a.radius * a.radius) - 1));
  }
  return phi;
}

TEST(gaussian_field, single_atom_sphere_has_radius_r_for_default_parameters) {
  molecule mol;
  mol.atoms.push_back({{1, 2, 3}, 1.7, 0});
  const gaussian_field field(mol, -1, 1);
  EXPECT_NEAR(field.value({1 + 1.7, 2, 3}), 1.0, 1e-12);
  EXPECT_GT(field.value({1 + 1.6, 2, 3}), 1.0);
  EXPECT_LT(field.value({1 + 1.8, 2, 3}), 1.0);
}

TEST(gaussian_field, cutoff_error_stays_within_the_stated_bound) {
  const molecule mol = random_cluster(400, 7);
  for (const double d : {-1.0, -0.5, -3.0}) {
    const gaussian_field field(mol, d, 1.0);
    EXPECT_LE(field.cutoff_error_bound(), 1e-6);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> coord(-14, 14);
    double worst = 0;
    for (int n = 0; n < 2000; ++n) {
      const vec3 p{coord(rng), coord(rng), coord(rng)};
      worst = std::max(worst, std::abs(field.value(p) - brute_force_phi(mol, p, d)));
    }
    EXPECT_LE(worst, field.cutoff_error_bound()) << "d = " << d;
    EXPECT_GT(worst, 0.0) << "the cutoff should drop something for a dense cluster";
  }
}

TEST(gaussian_field, gradient_matches_central_differences) {
  const molecule mol = random_cluster(60, 3);
  const gaussian_field field(mol, -1, 1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coord(-9, 9);
  for (int n = 0; n < 200; ++n) {
    const vec3 p{coord(rng), coord(rng), coord(rng)};
    vec3 g;
    const double phi = field.value_and_gradient(p, g);
    EXPECT_DOUBLE_EQ(phi, field.value(p));
    const double step = 1e-5;
    for (int axis = 0; axis < 3; ++axis) {
      vec3 a = p, b = p;
      a[axis] -= step;
      b[axis] += step;
      const double numeric = (field.value(b) - field.value(a)) / (2 * step);
      EXPECT_NEAR(g[axis], numeric, 1e-5 * (1 + std::abs(numeric)));
    }
  }
}

TEST(gaussian_field, radius_zero_atoms_do_not_contribute) {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, 1.5, 0});
  mol.atoms.push_back({{0.5, 0, 0}, 0.0, 0.4});
  const gaussian_field field(mol, -1, 1);
  EXPECT_EQ(field.atom_count(), 1u);
  EXPECT_NEAR(field.value({1.5, 0, 0}), 1.0, 1e-12);
  EXPECT_EQ(field.dominant_atom({1.5, 0, 0}), 0u);
}

TEST(gaussian_field, dominant_atom_is_the_nearest_of_equal_atoms) {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, 1.5, 0});
  mol.atoms.push_back({{3, 0, 0}, 1.5, 0});
  const gaussian_field field(mol, -1, 1);
  EXPECT_EQ(field.dominant_atom({-1.4, 0, 0}), 0u);
  EXPECT_EQ(field.dominant_atom({4.4, 0.2, 0}), 1u);
}

TEST(gaussian_field, projection_lands_on_the_surface) {
  const molecule mol = random_cluster(80, 9);
  const gaussian_field field(mol, -1, 1);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> coord(-10, 10);
  int projected = 0;
  for (int n = 0; n < 300; ++n) {
    vec3 p{coord(rng), coord(rng), coord(rng)};
    if (field.surface_distance(p) > 0.5) continue;
    if (!field.project_to_surface(p, 1.0)) continue;
    ++projected;
    EXPECT_LT(field.surface_distance(p), 1e-9);
  }
  EXPECT_GT(projected, 20);
}

TEST(gaussian_field, atoms_far_apart_need_no_dense_structure) {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, 1.5, 0});
  mol.atoms.push_back({{1e5, 0, 0}, 1.5, 0});
  const gaussian_field field(mol, -1, 1);
  EXPECT_NEAR(field.value({1e5 + 1.5, 0, 0}), 1.0, 1e-9);
  EXPECT_NEAR(field.value({-1.5, 0, 0}), 1.0, 1e-12);
  std::vector<std::uint32_t> near;
  field.atoms_near_box({{-2, -2, -2}, {2, 2, 2}}, near);
  ASSERT_EQ(near.size(), 1u);
  EXPECT_EQ(field.atom_at(near[0]).original_index, 0u);
}

}  // namespace
}  // namespace tracemesh
