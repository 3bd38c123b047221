#include "core/trace/legendre.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace tracemesh {
namespace {

/// The series of f (degree `degree`) from `points` Gauss nodes (eq. 6).
std::vector<double> fit(double (*f)(double), int degree, int points) {
  const gauss_legendre_rule rule = gauss_legendre(points);
  std::vector<double> values;
  for (const double s : rule.nodes) values.push_back(f(s));
  std::vector<double> a(static_cast<std::size_t>(degree + 1));
  legendre_coefficients(rule, values, a);
  return a;
}

/// Σ aₙPₙ(s), term by term from legendre_polynomial (not Clenshaw).
double direct_sum(const std::vector<double>& a, double s) {
  double sum = 0;
  for (std::size_t n = 0; n < a.size(); ++n) sum += a[n] * legendre_polynomial(static_cast<int>(n), s);
  return sum;
}

/// i_n(1) = √(π/2)·I_{n+1/2}(1) (modified spherical Bessel function) from its power series
/// i_n(x) = xⁿ Σ_k (x²/2)^k / (k!·(2n + 2k + 1)!!).
double spherical_bessel_i_at_1(int n) {
  double sum = 0;
  for (int k = 0; k < 30; ++k) {
    double term = std::pow(0.5, k) / std::tgamma(k + 1.0);
    for (int odd = 1; odd <= 2 * n + 2 * k + 1; odd += 2) term /= odd;
    sum += term;
  }
  return sum;
}

TEST(legendre, gauss_rules_of_two_and_three_points) {
  const gauss_legendre_rule two = gauss_legendre(2);
  EXPECT_NEAR(two.nodes[0], -1 / std::sqrt(3.0), 3e-16);
  EXPECT_NEAR(two.nodes[1], 1 / std::sqrt(3.0), 3e-16);
  EXPECT_NEAR(two.weights[0], 1, 1e-15);
  EXPECT_NEAR(two.weights[1], 1, 1e-15);
  const gauss_legendre_rule three = gauss_legendre(3);
  EXPECT_NEAR(three.nodes[0], -std::sqrt(0.6), 3e-16);
  EXPECT_EQ(three.nodes[1], 0.0);
  EXPECT_NEAR(three.nodes[2], std::sqrt(0.6), 3e-16);
  EXPECT_NEAR(three.weights[0], 5.0 / 9, 1e-15);
  EXPECT_NEAR(three.weights[1], 8.0 / 9, 1e-15);
  EXPECT_NEAR(three.weights[2], 5.0 / 9, 1e-15);
}

// An n-point rule integrates s^k exactly for k ≤ 2n − 1: ∫₋₁¹ s^k = 2/(k + 1) for even k, 0 for odd k.
TEST(legendre, gauss_rules_integrate_monomials_exactly) {
  for (int points : {1, 4, 11, 20, 41}) {
    const gauss_legendre_rule rule = gauss_legendre(points);
    ASSERT_EQ(rule.nodes.size(), static_cast<std::size_t>(points));
    EXPECT_TRUE(std::is_sorted(rule.nodes.begin(), rule.nodes.end()));
    for (int m = 0; m < points; ++m) {
      EXPECT_EQ(rule.nodes[static_cast<std::size_t>(m)], -rule.nodes[static_cast<std::size_t>(points - 1 - m)]);
    }
    for (int k = 0; k <= 2 * points - 1; ++k) {
      double sum = 0;
      for (int m = 0; m < points; ++m) {
        sum += rule.weights[static_cast<std::size_t>(m)] * std::pow(rule.nodes[static_cast<std::size_t>(m)], k);
      }
      const double exact = k % 2 == 0 ? 2.0 / (k + 1) : 0.0;
      EXPECT_NEAR(sum, exact, 1e-14) << points << " points, s^" << k;
    }
  }
}

TEST(legendre, polynomials_at_known_points) {
  for (int n = 0; n <= 12; ++n) {
    EXPECT_NEAR(legendre_polynomial(n, 1), 1, 1e-15);
    EXPECT_NEAR(legendre_polynomial(n, -1), n % 2 == 0 ? 1 : -1, 1e-15);
  }
  EXPECT_NEAR(legendre_polynomial(2, 0.3), (3 * 0.09 - 1) / 2, 1e-16);
  EXPECT_NEAR(legendre_polynomial(3, 0.3), (5 * 0.027 - 3 * 0.3) / 2, 1e-16);
  EXPECT_NEAR(legendre_polynomial(4, -0.7), (35 * std::pow(0.7, 4) - 30 * 0.49 + 3) / 8, 1e-15);
}

// s³ = 3/5·P₁ + 2/5·P₃ (eq. 6 recovers it exactly from 11 nodes).
TEST(legendre, coefficients_of_a_cube) {
  const std::vector<double> a = fit([](double s) { return s * s * s; }, 10, 11);
  for (std::size_t n = 0; n < a.size(); ++n) {
    const double expected = n == 1 ? 0.6 : n == 3 ? 0.4 : 0.0;
    EXPECT_NEAR(a[n], expected, 4e-15) << "n = " << n;
  }
  // The fitter's matrix form gives the same numbers.
  const legendre_fitter fitter(10);
  std::vector<double> values, b(11);
  for (const double s : fitter.rule().nodes) values.push_back(s * s * s);
  fitter.coefficients(values, b);
  for (std::size_t n = 0; n < a.size(); ++n) EXPECT_NEAR(b[n], a[n], 4e-15);
}

// exp(s) = Σ (2n+1)·i_n(1)·Pₙ(s), i_n the modified spherical Bessel function (i_n(1) = √(π/2)·I_{n+1/2}(1)).
TEST(legendre, coefficients_of_the_exponential) {
  const std::vector<double> a = fit([](double s) { return std::exp(s); }, 10, 11);
  const std::vector<double> a30 = fit([](double s) { return std::exp(s); }, 10, 30);
  for (int n = 0; n <= 10; ++n) {
    const double expected = (2 * n + 1) * spherical_bessel_i_at_1(n);
    // 11 nodes: the interpolating series, which differs from the projection by the aliased tail (a₁₂ ≈ 3e-12).
    EXPECT_NEAR(a[static_cast<std::size_t>(n)], expected, 5e-12) << "n = " << n;
    // 30 nodes: the projection itself, to rounding.
    EXPECT_NEAR(a30[static_cast<std::size_t>(n)], expected, 4e-15 * (1 + std::abs(expected))) << "n = " << n;
  }
  EXPECT_NEAR(spherical_bessel_i_at_1(0), std::sinh(1.0), 5e-16);  // the series itself, checked
  EXPECT_NEAR(spherical_bessel_i_at_1(1), std::cosh(1.0) - std::sinh(1.0), 5e-16);
  // The interpolating fit is within the interpolation error bound e/11!·max|Π(s − sₘ)| ≈ 7e-11 of exp.
  for (double s = -1; s <= 1; s += 0.01) EXPECT_NEAR(legendre_value(a, s), std::exp(s), 1e-10);
}

TEST(legendre, clenshaw_matches_the_direct_sum_and_its_derivative) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coefficient(-1, 1);
  for (int degree : {0, 1, 2, 5, 10, 25}) {
    std::vector<double> a(static_cast<std::size_t>(degree + 1));
    for (double& c : a) c = coefficient(rng);
    for (double s = -1; s <= 1.0001; s += 0.0625) {
      EXPECT_NEAR(legendre_value(a, s), direct_sum(a, s), 1e-13);
      double slope = 0;
      EXPECT_NEAR(legendre_value(a, s, slope), direct_sum(a, s), 1e-13);
      const double step = 1e-6;
      const double numeric = (direct_sum(a, s + step) - direct_sum(a, s - step)) / (2 * step);
      EXPECT_NEAR(slope, numeric, 1e-6 * (1 + degree * degree)) << "degree " << degree << ", s = " << s;
    }
  }
}

TEST(legendre, bernstein_form_has_the_same_values) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> coefficient(-1, 1);
  for (int degree : {1, 3, 10, 20, legendre_max_degree}) {
    std::vector<double> a(static_cast<std::size_t>(degree + 1)), b(a.size());
    for (double& c : a) c = coefficient(rng);
    legendre_to_bernstein(a, b);
    for (double u = 0; u <= 1.0001; u += 0.05) {
      double sum = 0;
      for (int j = 0; j <= degree; ++j) {
        sum += b[static_cast<std::size_t>(j)] * std::tgamma(degree + 1.0) /
               (std::tgamma(j + 1.0) * std::tgamma(degree - j + 1.0)) * std::pow(u, j) * std::pow(1 - u, degree - j);
      }
      // The Bernstein coefficients of Pₙ reach C(n, n/2): conversion rounding grows with it.
      const double conditioning = std::tgamma(degree + 1.0) / std::pow(std::tgamma(degree / 2 + 1.0), 2);
      EXPECT_NEAR(sum, legendre_value(a, 2 * u - 1), 1e-14 * conditioning) << "degree " << degree << ", u = " << u;
    }
  }
}

/// The Legendre series of Π (s − rᵢ) · q(s) from its values at degree + 1 nodes (exact: the product has that degree).
std::vector<double> series_from_roots(const std::vector<double>& roots, double (*q)(double), int q_degree) {
  const int degree = static_cast<int>(roots.size()) + q_degree;
  const gauss_legendre_rule rule = gauss_legendre(degree + 1);
  std::vector<double> values;
  for (const double s : rule.nodes) {
    double p = q(s);
    for (const double r : roots) p *= s - r;
    values.push_back(p);
  }
  std::vector<double> a(static_cast<std::size_t>(degree + 1));
  legendre_coefficients(rule, values, a);
  return a;
}

TEST(legendre, roots_of_a_series_built_from_chosen_roots) {
  // Five roots in [−1, 1] (two of them 1e-4 apart), one outside, and a complex pair (s² + 0.04): degree 8.
  const std::vector<double> chosen{-0.93, -0.3, 0.1, 0.1001, 0.75, 1.4};
  const std::vector<double> a = series_from_roots(
      chosen, [](double s) { return s * s + 0.04; }, 2);
  std::vector<double> roots;
  legendre_roots(a, roots);
  ASSERT_EQ(roots.size(), 5u);
  // The close pair is ill-conditioned (|p'| ≈ 1e-5 there): rounding of 1e-16 in the series moves it by ~1e-11.
  for (std::size_t n = 0; n < 5; ++n) EXPECT_NEAR(roots[n], chosen[n], n == 2 || n == 3 ? 2e-11 : 1e-14);
}

TEST(legendre, roots_at_the_ends_and_none_when_the_series_stays_positive) {
  std::vector<double> roots;
  legendre_roots(series_from_roots(
                     {-1.0, 1.0}, [](double) { return 1.0; }, 0),
                 roots);
  ASSERT_EQ(roots.size(), 2u);
  EXPECT_NEAR(roots[0], -1, 1e-15);
  EXPECT_NEAR(roots[1], 1, 1e-15);
  roots.clear();
  legendre_roots(series_from_roots(
                     {}, [](double s) { return s * s + 1e-3; }, 2),
                 roots);
  EXPECT_TRUE(roots.empty());
  legendre_roots(std::vector<double>{0, 0, 0}, roots);
  EXPECT_TRUE(roots.empty());
  legendre_roots(std::vector<double>{0.5}, roots);
  EXPECT_TRUE(roots.empty());
  legendre_roots(std::vector<double>{0.25, 1}, roots);  // 0.25 + s
  ASSERT_EQ(roots.size(), 1u);
  EXPECT_NEAR(roots[0], -0.25, 1e-16);
}

// Random series against a dense sign scan: every sign change of the series on a fine grid holds a reported root.
TEST(legendre, random_series_roots_match_a_dense_scan) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> coefficient(-1, 1);
  int total = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<double> a(11);
    for (double& c : a) c = coefficient(rng);
    std::vector<double> roots;
    legendre_roots(a, roots);
    EXPECT_TRUE(std::is_sorted(roots.begin(), roots.end()));
    for (const double r : roots) {
      EXPECT_GE(r, -1);
      EXPECT_LE(r, 1);
      double slope = 0;
      const double value = legendre_value(a, r, slope);
      EXPECT_LE(std::abs(value), 1e-13 * (1 + std::abs(slope))) << "trial " << trial;
    }
    constexpr int n = 20000;
    std::size_t scanned = 0;
    double previous = legendre_value(a, -1);
    for (int m = 1; m <= n; ++m) {
      const double s = -1 + 2.0 * m / n, value = legendre_value(a, s);
      if ((value >= 0) != (previous >= 0)) {
        ++scanned;
        const double lo = s - 2.0 / n, hi = s;
        EXPECT_TRUE(
            std::any_of(roots.begin(), roots.end(), [&](double r) { return r >= lo - 1e-12 && r <= hi + 1e-12; }))
            << "trial " << trial << ": sign change in [" << lo << ", " << hi << "] without a root";
      }
      previous = value;
    }
    EXPECT_GE(roots.size(), scanned);
    total += static_cast<int>(roots.size());
  }
  EXPECT_GT(total, 300);
}

}  // namespace
}  // namespace tracemesh
