#include "core/trace/legendre.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace tracemesh {
namespace {

/// Pieces narrower than this (in u = (s + 1)/2) that still show several sign changes are not split further.
constexpr int max_subdivision_depth = 40;
/// Polishing of an isolated root stops when a Newton step is below the caller's tolerance, or the bracket below
/// root_bracket_tolerance (in s), or once the steps are below noise_step and stop shrinking (rounding noise in the
/// series' value).
constexpr double noise_step = 1e-10;
constexpr double root_bracket_tolerance = 4e-16;
constexpr int max_polish_iterations = 100;

using bernstein_array = std::array<double, legendre_max_degree + 1>;

/// The constants of Clenshaw's recurrence for Legendre series, (2k+1)/(k+1) and (k+1)/(k+2), as tables for the
/// degrees supported (no divisions in the recurrence).
constexpr std::array<double, legendre_max_degree + 1> make_clenshaw_table(bool alpha) {
  std::array<double, legendre_max_degree + 1> table{};
  for (int k = 0; k <= legendre_max_degree; ++k) {
    table[static_cast<std::size_t>(k)] = alpha ? (2 * k + 1) / (k + 1.0) : (k + 1.0) / (k + 2);
  }
  return table;
}
constexpr std::array<double, legendre_max_degree + 1> clenshaw_alpha = make_clenshaw_table(true);
constexpr std::array<double, legendre_max_degree + 1> clenshaw_beta = make_clenshaw_table(false);

double alpha_of(int k) {
  return k <= legendre_max_degree ? clenshaw_alpha[static_cast<std::size_t>(k)] : (2 * k + 1) / (k + 1.0);
}
double beta_of(int k) {
  return k <= legendre_max_degree ? clenshaw_beta[static_cast<std::size_t>(k)] : (k + 1.0) / (k + 2);
}

/// Pₙ(s) and Pₙ₋₁(s) by the recurrence (n + 1)Pₙ₊₁ = (2n + 1)sPₙ − nPₙ₋₁ (n ≥ 1).
void legendre_pair(int n, double s, double& p_n, double& p_previous) {
  double previous = 1, current = s;
  for (int k = 1; k < n; ++k) {
    const double next = ((2 * k + 1) * s * current - k * previous) / (k + 1);
    previous = current;
    current = next;
  }
  p_n = current;
  p_previous = previous;
}

/// Binomial coefficient C(n, k) as a double (exact for the degrees supported).
double binomial(int n, int k) {
  if (k < 0 || k > n) return 0;
  double c = 1;
  for (int i = 1; i <= k; ++i) c = c * (n - k + i) / i;
  return c;
}

/// Bernstein coefficient j (degree m) of Pₙ(2u − 1): Pₙ has degree-n coefficients (−1)^(n−k)·C(n, k), raised to degree
/// m by B^n_k = Σⱼ C(n,k)·C(m−n, j−k)/C(m, j)·B^m_j.
double legendre_bernstein_entry(int m, int n, int j) {
  double sum = 0;
  for (int k = std::max(0, j - (m - n)); k <= std::min(n, j); ++k) {
    const double c = binomial(n, k);
    sum += ((n - k) % 2 == 0 ? 1.0 : -1.0) * c * c * binomial(m - n, j - k);
  }
  return sum / binomial(m, j);
}

/// Sign changes in a Bernstein coefficient sequence, 0 counted as positive (so a root exactly at a split point
/// belongs to exactly one side of a crossing).
int sign_variations(const double* b, int count) {
  int changes = 0;
  for (int j = 1; j < count; ++j) changes += (b[j] >= 0) != (b[j - 1] >= 0);
  return changes;
}

/// De Casteljau at u = 1/2: the coefficients of the left and right halves.
void split_half(const double* b, int count, double* left, double* right) {
  bernstein_array work;
  std::copy(b, b + count, work.begin());
  for (int level = 0; level < count; ++level) {
    left[level] = work[0];
    right[count - 1 - level] = work[static_cast<std::size_t>(count - 1 - level)];
    for (int j = 0; j + 1 < count - level; ++j) work[j] = 0.5 * (work[j] + work[j + 1]);
  }
}

/// The root of the series in [lo, hi] (s), where its values at the ends, value_lo and value_hi, have opposite signs
/// (0 counts as positive): safeguarded Newton from the regula falsi point of the end values.
double polish_root(std::span<const double> a, double lo, double hi, double value_lo, double value_hi,
                   double tolerance) {
  const bool lo_positive = value_lo >= 0;
  double s = value_lo != value_hi ? lo + (hi - lo) * (value_lo / (value_lo - value_hi)) : 0.5 * (lo + hi);
  if (!(s > lo && s < hi)) s = 0.5 * (lo + hi);
  double previous_step = std::numeric_limits<double>::infinity();
  for (int iteration = 0; iteration < max_polish_iterations; ++iteration) {
    double slope = 0;
    const double value = legendre_value(a, s, slope);
    if (value == 0) return s;
    ((value >= 0) == lo_positive ? lo : hi) = s;
    const double step = slope != 0 ? value / slope : std::numeric_limits<double>::infinity();
    if (std::abs(step) <= tolerance || (std::abs(step) <= noise_step && std::abs(step) > 0.5 * previous_step)) {
      return std::clamp(s - step, lo, hi);
    }
    previous_step = std::abs(step);
    double next = s - step;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (hi - lo <= root_bracket_tolerance) return next;
    s = next;
  }
  return s;
}

/// Roots in the piece [u_lo, u_lo + width] whose Bernstein coefficients are b (count of them), ascending.
void isolate(std::span<const double> a, const double* b, int count, double u_lo, double width, int depth, double scale,
             double tolerance, std::vector<double>& roots) {
  const int changes = sign_variations(b, count);
  if (changes == 0) return;
  const double s_lo = 2 * u_lo - 1, s_hi = 2 * (u_lo + width) - 1;
  if (changes == 1) {
    // One simple root, with opposite signs at the ends. The ends are evaluated on the series itself (Clenshaw is
    // better conditioned than the Bernstein form); should rounding make them agree, the piece is split further.
    const double value_lo = legendre_value(a, s_lo), value_hi = legendre_value(a, s_hi);
    if ((value_lo >= 0) != (value_hi >= 0)) {
      roots.push_back(polish_root(a, s_lo, s_hi, value_lo, value_hi, tolerance));
      return;
    }
  }
  if (depth >= max_subdivision_depth) {
    // Not separable in double precision: a multiple root or a tight cluster. Report it if the series vanishes here.
    const double s_mid = 0.5 * (s_lo + s_hi);
    if (std::abs(legendre_value(a, s_mid)) <= 1e-12 * scale) roots.push_back(s_mid);
    return;
  }
  bernstein_array left, right;
  split_half(b, count, left.data(), right.data());
  isolate(a, left.data(), count, u_lo, 0.5 * width, depth + 1, scale, tolerance, roots);
  isolate(a, right.data(), count, u_lo + 0.5 * width, 0.5 * width, depth + 1, scale, tolerance, roots);
}

void check_degree(std::size_t coefficient_count) {
  if (coefficient_count > legendre_max_degree + 1) throw std::invalid_argument("legendre: degree above the maximum");
}

}  // namespace

gauss_legendre_rule gauss_legendre(int points) {
  if (points < 1) throw std::invalid_argument("gauss_legendre: points < 1");
  gauss_legendre_rule rule;
  rule.nodes.assign(static_cast<std::size_t>(points), 0.0);
  rule.weights.assign(static_cast<std::size_t>(points), 0.0);
  const double n = points;
  for (int i = 0; i < (points + 1) / 2; ++i) {
    // The i-th largest root of P_n (Tricomi's first-order guess), then Newton to convergence.
    double s = std::cos(M_PI * (i + 0.75) / (n + 0.5));
    double derivative = 0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p = 0, p_previous = 0;
      legendre_pair(points, s, p, p_previous);
      derivative = n * (s * p - p_previous) / (s * s - 1);
      const double step = p / derivative;
      s -= step;
      if (std::abs(step) <= 1e-17) break;
    }
    double p = 0, p_previous = 0;
    legendre_pair(points, s, p, p_previous);
    derivative = n * (s * p - p_previous) / (s * s - 1);
    if (2 * i + 1 == points) s = 0;  // the middle node of an odd rule
    const double weight = 2 / ((1 - s * s) * derivative * derivative);
    const auto high = static_cast<std::size_t>(points - 1 - i), low = static_cast<std::size_t>(i);
    rule.nodes[high] = s;
    rule.nodes[low] = -s;
    rule.weights[high] = rule.weights[low] = weight;
  }
  return rule;
}

double legendre_polynomial(int n, double s) {
  if (n == 0) return 1;
  double p = 0, p_previous = 0;
  legendre_pair(n, s, p, p_previous);
  return p;
}

void legendre_coefficients(const gauss_legendre_rule& rule, std::span<const double> values,
                           std::span<double> coefficients) {
  std::fill(coefficients.begin(), coefficients.end(), 0.0);
  const int degree = static_cast<int>(coefficients.size()) - 1;
  for (std::size_t m = 0; m < rule.nodes.size(); ++m) {
    const double s = rule.nodes[m], weighted = rule.weights[m] * values[m];
    double previous = 0, current = 1;  // P₋₁ (unused), P₀
    for (int n = 0; n <= degree; ++n) {
      coefficients[static_cast<std::size_t>(n)] += weighted * current;
      const double next = ((2 * n + 1) * s * current - n * previous) / (n + 1);
      previous = current;
      current = next;
    }
  }
  for (int n = 0; n <= degree; ++n) coefficients[static_cast<std::size_t>(n)] *= (2 * n + 1) / 2.0;
}

double legendre_value(std::span<const double> coefficients, double s) {
  // b_k = a_k + α_k b_{k+1} + β_{k+1} b_{k+2}, α_k = (2k+1)s/(k+1), β_k = −k/(k+1); the series is b₀.
  double b1 = 0, b2 = 0;
  for (int k = static_cast<int>(coefficients.size()) - 1; k >= 0; --k) {
    const double b0 = coefficients[static_cast<std::size_t>(k)] + alpha_of(k) * s * b1 - beta_of(k) * b2;
    b2 = b1;
    b1 = b0;
  }
  return b1;
}

double legendre_value(std::span<const double> coefficients, double s, double& derivative) {
  // Clenshaw's recurrence and its derivative in s: b'_k = α_k b'_{k+1} + α'_k b_{k+1} + β_{k+1} b'_{k+2}.
  double b1 = 0, b2 = 0, d1 = 0, d2 = 0;
  for (int k = static_cast<int>(coefficients.size()) - 1; k >= 0; --k) {
    const double alpha_slope = alpha_of(k), beta = beta_of(k);
    const double b0 = coefficients[static_cast<std::size_t>(k)] + alpha_slope * s * b1 - beta * b2;
    const double d0 = alpha_slope * s * d1 + alpha_slope * b1 - beta * d2;
    b2 = b1;
    b1 = b0;
    d2 = d1;
    d1 = d0;
  }
  derivative = d1;
  return b1;
}

void legendre_to_bernstein(std::span<const double> coefficients, std::span<double> bernstein) {
  check_degree(coefficients.size());
  const int m = static_cast<int>(coefficients.size()) - 1;
  for (int j = 0; j <= m; ++j) {
    double sum = 0;
    for (int n = 0; n <= m; ++n) sum += coefficients[static_cast<std::size_t>(n)] * legendre_bernstein_entry(m, n, j);
    bernstein[static_cast<std::size_t>(j)] = sum;
  }
}

void legendre_roots(std::span<const double> coefficients, std::vector<double>& roots, double tolerance) {
  check_degree(coefficients.size());  // before a span of that size is made over the fixed-size array
  bernstein_array b{};
  legendre_to_bernstein(coefficients, std::span<double>(b.data(), coefficients.size()));
  legendre_roots(coefficients, std::span<const double>(b.data(), coefficients.size()), roots, tolerance);
}

void legendre_roots(std::span<const double> coefficients, std::span<const double> bernstein, std::vector<double>& roots,
                    double tolerance) {
  check_degree(coefficients.size());
  if (bernstein.empty()) return;
  double scale = 0;
  for (const double b : bernstein) scale = std::max(scale, std::abs(b));
  if (scale == 0) return;  // identically zero
  const std::size_t first = roots.size();
  isolate(coefficients, bernstein.data(), static_cast<int>(bernstein.size()), 0.0, 1.0, 0, scale, tolerance, roots);
  // A root exactly on a split point can be reported by both pieces.
  const auto unique_end = std::unique(roots.begin() + static_cast<std::ptrdiff_t>(first), roots.end(),
                                      [](double x, double y) { return std::abs(x - y) <= 4 * root_bracket_tolerance; });
  roots.erase(unique_end, roots.end());
}

legendre_fitter::legendre_fitter(int degree) : degree_(degree) {
  if (degree < 1 || degree > legendre_max_degree) throw std::invalid_argument("legendre_fitter: degree out of range");
  const int count = degree + 1;
  rule_ = gauss_legendre(count);
  fit_.assign(static_cast<std::size_t>(count * count), 0.0);
  for (int n = 0; n < count; ++n) {
    for (int m = 0; m < count; ++m) {
      const auto mm = static_cast<std::size_t>(m);
      fit_[static_cast<std::size_t>(n * count + m)] =
          (2 * n + 1) / 2.0 * rule_.weights[mm] * legendre_polynomial(n, rule_.nodes[mm]);
    }
  }
}

void legendre_fitter::coefficients(std::span<const double> values, std::span<double> out) const {
  const auto count = static_cast<std::size_t>(degree_ + 1);
  for (std::size_t n = 0; n < count; ++n) {
    const double* row = fit_.data() + n * count;
    out[n] = std::inner_product(row, row + count, values.begin(), 0.0);
  }
}

}  // namespace tracemesh
