#include "core/field/gaussian_field.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
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

double ulps_between(double a, double b) {
  return std::abs(a - b) / (std::nextafter(std::max(a, b), std::numeric_limits<double>::infinity()) - std::max(a, b));
}

TEST(gaussian_field, kernel_exp_is_within_two_ulp_of_std_exp) {
  std::mt19937_64 rng(4);
  double worst = 0;
  for (const auto& [lo, hi] : {std::pair{-708.0, 709.0}, std::pair{-60.0, 25.0}, std::pair{-1e-3, 1e-3}}) {
    std::uniform_real_distribution<double> x(lo, hi);
    for (int n = 0; n < 200000; ++n) {
      const double v = x(rng);
      worst = std::max(worst, ulps_between(kernel_exp(v), std::exp(v)));
    }
  }
  EXPECT_LE(worst, 2.0);
  EXPECT_EQ(kernel_exp(0.0), 1.0);
  EXPECT_EQ(kernel_exp(1.0), std::exp(1.0));
  EXPECT_GT(kernel_exp(-708.0), 0.0);
  EXPECT_EQ(kernel_exp(-708.5), 0.0);  // below the normal range: exactly 0, never a wrapped exponent
  EXPECT_EQ(kernel_exp(-1e300), 0.0);
  EXPECT_EQ(kernel_exp(std::numeric_limits<double>::quiet_NaN()), 0.0);
}

// Every vector width computes the same bits in every lane: a lattice value is the same whichever lane computes it.
TEST(gaussian_field, vector_exp_lanes_equal_kernel_exp) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-80, 25);
  for (int n = 0; n < 1000; ++n) {
    simd::pack<2>::f64 two;
    simd::pack<4>::f64 four;
    simd::pack<8>::f64 eight;
    double input[8];
    for (double& v : input) v = x(rng);
    simd::load(two, input);
    simd::load(four, input);
    simd::load(eight, input);
    simd::exp_in_place(two);
    simd::exp_in_place(four);
    simd::exp_in_place(eight);
    for (int j = 0; j < 8; ++j) {
      const double expected = kernel_exp(input[j]);
      EXPECT_EQ(eight[j], expected);
      if (j < 4) {
        EXPECT_EQ(four[j], expected);
      }
      if (j < 2) {
        EXPECT_EQ(two[j], expected);
      }
    }
  }
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

// Atoms nearest the point by kernel value, by brute force over the molecule (ties: lower index).
std::uint32_t brute_force_dominant(const gaussian_field& field, const molecule& mol, const vec3& p) {
  std::uint32_t best_index = 0;
  double best = -1;
  for (std::uint32_t k = 0; k < field.atom_count(); ++k) {
    const auto a = field.atom_at(k);
    const double r2 = squared_norm(p - vec3{a.x, a.y, a.z});
    if (r2 >= a.cutoff2) continue;
    const double kernel = std::exp(field.d() * (r2 * a.inv_r2 - 1));
    if (kernel > best || (kernel == best && a.original_index < best_index)) {
      best = kernel;
      best_index = a.original_index;
    }
  }
  EXPECT_LT(best_index, mol.atoms.size());
  return best_index;
}

TEST(gaussian_field, probe_agrees_with_separate_evaluations_and_brute_force) {
  const molecule mol = random_cluster(300, 13);
  const gaussian_field field(mol, -1, 1);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> coord(-11, 11);
  for (int n = 0; n < 500; ++n) {
    const vec3 p{coord(rng), coord(rng), coord(rng)};
    const gaussian_field::point_probe probe = field.probe(p);
    vec3 g;
    const double phi = field.value_and_gradient(p, g);
    EXPECT_EQ(probe.value, phi);
    EXPECT_EQ(probe.gradient, g);
    EXPECT_EQ(field.value(p), phi);
    EXPECT_EQ(probe.dominant_atom, field.dominant_atom(p));
    EXPECT_NEAR(phi, brute_force_phi(mol, p, -1), 1e-6);
    if (phi > 1e-3) {
      EXPECT_EQ(probe.dominant_atom, brute_force_dominant(field, mol, p)) << "at " << p.x << " " << p.y;
    }
  }
}

TEST(gaussian_field, atoms_near_box_finds_every_atom_whose_cutoff_reaches_the_box) {
  const molecule mol = random_cluster(500, 17);
  const gaussian_field field(mol, -1, 1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> corner(-20, 15), size(0.1, 12);
  std::vector<std::uint32_t> near;
  for (int n = 0; n < 200; ++n) {
    const vec3 lo{corner(rng), corner(rng), corner(rng)};
    const box3 box{lo, lo + vec3{size(rng), size(rng), size(rng)}};
    field.atoms_near_box(box, near);
    EXPECT_TRUE(std::is_sorted(near.begin(), near.end()));
    std::size_t expected = 0;
    for (std::uint32_t k = 0; k < field.atom_count(); ++k) {
      const auto a = field.atom_at(k);
      vec3 gap;
      for (int axis = 0; axis < 3; ++axis) {
        const double c = vec3{a.x, a.y, a.z}[axis];
        gap[axis] = std::max({box.lo[axis] - c, 0.0, c - box.hi[axis]});
      }
      const double distance2 = squared_norm(gap);
      const bool listed = std::binary_search(near.begin(), near.end(), k);
      if (distance2 < a.cutoff2) {
        ++expected;
        EXPECT_TRUE(listed) << "atom " << k << " reaches the box but is missing";
      } else if (listed) {
        EXPECT_LT(distance2, a.cutoff2 * (1 + 1e-6)) << "atom " << k << " is listed but far from the box";
      }
    }
    EXPECT_GE(near.size(), expected);
  }
}

// A far atom on the diagonal makes the bounding box hold ~10¹³ cells, so the field falls back to hashed cell rows;
// cells are anchored at the origin and visited in the same order either way, so values agree bit for bit.
TEST(gaussian_field, hashed_rows_give_the_same_bits_as_the_dense_cell_table) {
  const molecule cluster = random_cluster(200, 21);
  molecule with_far_atom = cluster;
  with_far_atom.atoms.push_back({{1e5, 1e5, 1e5}, 1.5, 0});
  const gaussian_field dense(cluster, -1, 1), sparse(with_far_atom, -1, 1);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> coord(-10, 10);
  for (int n = 0; n < 300; ++n) {
    const vec3 p{coord(rng), coord(rng), coord(rng)};
    vec3 dense_gradient, sparse_gradient;
    EXPECT_EQ(dense.value_and_gradient(p, dense_gradient), sparse.value_and_gradient(p, sparse_gradient));
    EXPECT_EQ(dense_gradient, sparse_gradient);
    EXPECT_EQ(dense.dominant_atom(p), sparse.dominant_atom(p));
  }
  std::vector<std::uint32_t> dense_near, sparse_near;
  dense.atoms_near_box({{-3, -3, -3}, {4, 4, 4}}, dense_near);
  sparse.atoms_near_box({{-3, -3, -3}, {4, 4, 4}}, sparse_near);
  ASSERT_EQ(dense_near.size(), sparse_near.size());
  for (std::size_t n = 0; n < dense_near.size(); ++n) {
    EXPECT_EQ(dense.atom_at(dense_near[n]).original_index, sparse.atom_at(sparse_near[n]).original_index);
  }
  EXPECT_NEAR(sparse.value({1e5 + 1.5, 1e5, 1e5}), 1.0, 1e-9);
}

TEST(gaussian_field, no_contributing_atoms_give_an_empty_field) {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, 0.0, 1});
  const gaussian_field field(mol, -1, 1);
  EXPECT_EQ(field.atom_count(), 0u);
  EXPECT_EQ(field.value({0, 0, 0}), 0.0);
  std::vector<std::uint32_t> near{1, 2};
  field.atoms_near_box({{-1, -1, -1}, {1, 1, 1}}, near);
  EXPECT_TRUE(near.empty());
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

// A walk in a plane through a neighbourhood: every value and gradient is the field's, bit for bit, and a box serves
// many points (the walk leaves the plane's flat box only along the plane).
TEST(gaussian_field, neighbourhood_evaluations_are_the_field_s_bits) {
  const molecule cluster = random_cluster(400, 31);
  const gaussian_field field(cluster, -1, 1);
  field_neighbourhood near(field, {1.0, 1.0, 0.0});
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> step(-0.25, 0.25);
  vec3 p{-6, -6, 0.3};
  const int points = 600;
  for (int n = 0; n < points; ++n) {
    p.x += 0.02 + step(rng) * 0.2;
    p.y += 0.02 + step(rng) * 0.2;
    vec3 expected_gradient, gradient;
    const double expected = field.value_and_gradient(p, expected_gradient);
    EXPECT_EQ(near.value_and_gradient(p, gradient), expected);
    EXPECT_EQ(gradient, expected_gradient);
  }
  EXPECT_LT(near.gathers(), static_cast<std::size_t>(points / 10));
  EXPECT_GT(near.atom_count(), 0u);
  // Off the plane the box is left at every point, and the values stay the field's.
  for (int n = 0; n < 50; ++n) {
    const vec3 q{step(rng) * 20, step(rng) * 20, step(rng) * 20};
    vec3 expected_gradient, gradient;
    EXPECT_EQ(near.value_and_gradient(q, gradient), field.value_and_gradient(q, expected_gradient));
    EXPECT_EQ(gradient, expected_gradient);
  }
}

// So many atoms within their cutoff of one point that the evaluation's list fills several times: the cell rows and a
// neighbourhood's single list fill at different atoms, and still give the same bits (every atom keeps its lane).
TEST(gaussian_field, a_full_atom_list_does_not_change_the_sum) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> coord(-2, 2);
  molecule crowd;
  for (int n = 0; n < 900; ++n) crowd.atoms.push_back({{coord(rng), coord(rng), coord(rng)}, 1.5, 0});
  const gaussian_field field(crowd, -1, 1);
  field_neighbourhood near(field, {0.5, 0.5, 0.5});
  for (const vec3& p : {vec3{0, 0, 0}, vec3{0.3, -0.2, 0.1}, vec3{-0.4, 0.4, -0.45}}) {
    vec3 expected_gradient, gradient;
    const double expected = field.value_and_gradient(p, expected_gradient);
    EXPECT_EQ(near.value_and_gradient(p, gradient), expected);
    EXPECT_EQ(gradient, expected_gradient);
    EXPECT_NEAR(expected, brute_force_phi(crowd, p, -1), 1e-12 * expected);
  }
  EXPECT_EQ(near.gathers(), 1u);
  EXPECT_EQ(near.atom_count(), crowd.atoms.size());
}

}  // namespace
}  // namespace tracemesh
