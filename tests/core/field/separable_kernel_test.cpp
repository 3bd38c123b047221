#include "core/field/separable_kernel.hpp"

#include <gtest/gtest.h>

#include <array>
#include <random>

namespace tracemesh {
namespace {

constexpr int entries = 24;  // a multiple of every width
using row = std::array<double, entries>;

/// A row of factors, squared offsets and running sums as the samplers hold them (sums ≥ 0).
struct kernel_row {
  row factor{}, offset2{}, sums{};
};

kernel_row random_row(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1), offset(0, 4.5);
  kernel_row r;
  for (int m = 0; m < entries; ++m) {
    r.factor[m] = unit(rng);
    r.offset2[m] = m % 3 == 0 ? 4.5 + offset(rng) : offset(rng);  // every third beyond the test's cutoff
    r.sums[m] = unit(rng);
  }
  return r;
}

/// add_kernel_terms of width W on [begin, end) of a copy of `r`.
template <int W>
row added(const kernel_row& r, double weight, double rho2, double cutoff2, int begin, int end) {
  row sums = r.sums;
  simd::add_kernel_terms<W>(sums.data(), r.factor.data(), r.offset2.data(), weight, rho2, cutoff2, begin, end);
  return sums;
}

// Every entry in the range gets factor·weight added where it is within the cutoff and keeps its bits elsewhere;
// entries outside the range are untouched; the vector lanes and the one-by-one rest agree bit for bit, at every
// width, as the lattice sampler (9 points a row) and the line roots (whole vectors) both rely on.
TEST(separable_kernel, kernel_terms_are_the_same_bits_at_every_width_and_in_the_rest) {
  const double weight = 0.37, rho2 = 2.5, cutoff2 = 7.0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const kernel_row r = random_row(seed);
    for (const auto& [begin, end] : {std::pair{0, 9}, std::pair{0, entries}, std::pair{3, 17}, std::pair{8, 16}}) {
      row expected = r.sums;
      int reached = 0;
      for (int m = begin; m < end; ++m) {
        if (r.offset2[m] + rho2 < cutoff2) {
          expected[m] += r.factor[m] * weight;
          ++reached;
        }
      }
      ASSERT_GT(reached, 0);
      ASSERT_LT(reached, end - begin) << "the row must hold entries on both sides of the cutoff";
      EXPECT_EQ(added<2>(r, weight, rho2, cutoff2, begin, end), expected);
      EXPECT_EQ(added<4>(r, weight, rho2, cutoff2, begin, end), expected);
      EXPECT_EQ(added<8>(r, weight, rho2, cutoff2, begin, end), expected);
    }
  }
}

// The 1-D factors are kernel_exp(d·δ²/r²), the same bits as every other exponential of the front end.
TEST(separable_kernel, axis_factors_are_kernel_exp_of_the_squared_offsets) {
  row coordinate{}, squared{}, factor{};
  for (int m = 0; m < entries; ++m) coordinate[m] = 0.7 * (m - 10);
  const double centre = 1.3, d = -1.0, inv_r2 = 1 / 2.25;
  simd::axis_factors<4>(coordinate.data(), entries, centre, d, inv_r2, squared.data(), factor.data());
  for (int m = 0; m < entries; ++m) {
    const double delta = coordinate[m] - centre;
    EXPECT_EQ(squared[m], delta * delta);
    EXPECT_EQ(factor[m], kernel_exp(d * (delta * delta) * inv_r2));
  }
}

}  // namespace
}  // namespace tracemesh
