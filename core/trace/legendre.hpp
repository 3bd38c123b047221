#pragma once
/// @file legendre.hpp
/// Legendre series on [−1, 1] for the line roots of TMSmesh (paper eq. 6): Gauss–Legendre quadrature, the series
/// of a function sampled at the quadrature nodes, its value (Clenshaw), its derivative, and its real roots.
///
/// Root finding (legendre_roots): the series is converted to the Bernstein basis on [−1, 1] (u = (s + 1)/2) and its
/// roots are isolated by subdivision (de Casteljau) with Descartes' rule of signs: a piece whose Bernstein
/// coefficients have no sign change holds no root (convex hull property), one with exactly one sign change holds
/// exactly one simple root, with opposite signs at its two ends; other pieces are halved. Each isolated root is then
/// polished by Newton steps on the Legendre series (Clenshaw), safeguarded by bisection inside its bracket.
/// Chosen over the paper's Jenkins–Traub (complex roots we do not need, no guarantee on [−1, 1]) and over
/// colleague-matrix eigenvalues (an O(M³) nonsymmetric eigensolver per fit): subdivision is O(M²) per piece, works
/// on real arithmetic only, and its first step is a certificate — a fit whose Bernstein coefficients all lie on
/// one side of the level has no root, which is how most fits along a line are dismissed. Roots of even multiplicity
/// (tangencies) are reported only when subdivision cannot separate them (a piece narrower than 2⁻⁴⁰ still showing
/// sign changes: its midpoint is returned).
///
/// Everything is deterministic: no state, no threads, fixed operation order.

#include <span>
#include <vector>

namespace tracemesh {

/// Largest series degree supported (mesh_params allows up to parameter_ranges::max_legendre_degree = 30). The
/// Bernstein coefficients of Pₙ reach C(n, n/2) (252 for n = 10, 1.6e8 for n = 30), so the conversion loses up to
/// that factor of precision; the root finder only uses the Bernstein form to isolate roots (end signs and polishing
/// are on the Legendre series), so at degree 30 it may miss only roots where the series stays within ~1e-8 of the
/// level (near tangencies).
inline constexpr int legendre_max_degree = 30;

/// Gauss–Legendre rule with `points` nodes on [−1, 1]: ∫₋₁¹ f ≈ Σ wₘ f(sₘ), exact for polynomials of degree
/// ≤ 2·points − 1. Nodes ascending and exactly antisymmetric (s[m] = −s[points−1−m]); weights symmetric.
struct gauss_legendre_rule {
  std::vector<double> nodes;
  std::vector<double> weights;
};

/// The rule with `points` ≥ 1 nodes (Newton on P_points from the asymptotic guesses, to full double precision).
gauss_legendre_rule gauss_legendre(int points);

/// Pₙ(s) by the three-term recurrence (n ≥ 0).
double legendre_polynomial(int n, double s);

/// The degree-M series Σₙ aₙPₙ of f from its values at the rule's nodes (paper eq. 6):
/// aₙ = (2n+1)/2 ∫₋₁¹ f(s) Pₙ(s) ds, the integral by the rule. With points = M + 1 the series interpolates f at the
/// nodes. `coefficients` has M + 1 entries (M ≤ points − 1); `values` has rule.nodes.size() entries.
void legendre_coefficients(const gauss_legendre_rule& rule, std::span<const double> values,
                           std::span<double> coefficients);

/// Σₙ aₙPₙ(s) by Clenshaw's recurrence. An empty series is 0.
double legendre_value(std::span<const double> coefficients, double s);
/// Σₙ aₙPₙ(s) and its derivative d/ds (written to `derivative`), by Clenshaw's recurrence differentiated.
double legendre_value(std::span<const double> coefficients, double s, double& derivative);

/// Bernstein coefficients bⱼ, j = 0..M, of Σₙ aₙPₙ(s) on [−1, 1]: Σ aₙPₙ(2u − 1) = Σⱼ bⱼ C(M,j) uʲ(1 − u)^(M−j).
/// b₀ and b_M are the values at s = −1 and s = 1. M = coefficients.size() − 1 ≤ legendre_max_degree.
void legendre_to_bernstein(std::span<const double> coefficients, std::span<double> bernstein);

/// Appends to `roots` the real roots s ∈ [−1, 1] of Σₙ aₙPₙ(s) (subtract a level from a₀ to solve Σ aₙPₙ = level),
/// ascending, each polished until a Newton step is at most `tolerance` (in s; or stops shrinking below 1e-10, the
/// rounding noise of the series). Roots of odd multiplicity are found; see the file comment for even ones. An
/// identically zero series has none. Degree ≤ legendre_max_degree (std::invalid_argument otherwise).
void legendre_roots(std::span<const double> coefficients, std::vector<double>& roots, double tolerance = 1e-14);

/// The same, with the Bernstein coefficients already computed (legendre_to_bernstein of `coefficients`).
void legendre_roots(std::span<const double> coefficients, std::span<const double> bernstein, std::vector<double>& roots,
                    double tolerance = 1e-14);

/// A degree-M fit with its tables computed once: the (M+1)-point Gauss rule and the matrix of eq. 6 (values at the
/// nodes → Legendre coefficients). Immutable after construction: one object may be shared by threads.
class legendre_fitter {
 public:
  /// 1 ≤ degree ≤ legendre_max_degree; std::invalid_argument otherwise (a programmer error: mesh_params are
  /// validated against parameter_ranges first).
  explicit legendre_fitter(int degree);

  /// Quadrature points per fit: degree + 1.
  int points() const { return degree_ + 1; }
  const gauss_legendre_rule& rule() const { return rule_; }

  /// Eq. 6: aₙ (n = 0..M) from f at the nodes (points() values). Same numbers as legendre_coefficients, other order
  /// of summation (a fixed matrix–vector product).
  void coefficients(std::span<const double> values, std::span<double> out) const;

 private:
  int degree_;
  gauss_legendre_rule rule_;
  std::vector<double> fit_;  ///< (M+1) × (M+1): fit_[n·(M+1) + m] = (2n+1)/2 · wₘ · Pₙ(sₘ)
};

}  // namespace tracemesh
