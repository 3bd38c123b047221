#include "core/analysis/analysis_predicates.hpp"

#include <array>
#include <cmath>
#include <cstddef>

#include "core/vec3.hpp"

namespace tracemesh::detail {
namespace {

/// Unit roundoff of double, 2⁻⁵³.
constexpr double epsilon = 1.0 / 9007199254740992.0;
/// Relative error bounds of the floating-point determinants (Shewchuk: orient2d (3 + 16ε)ε, orient3d
/// (7 + 56ε)ε), rounded up: |computed − exact| ≤ bound · permanent.
constexpr double orient2d_error_bound = 4 * epsilon;
constexpr double orient3d_error_bound = 8 * epsilon;

/// hi + lo represents a value exactly.
struct exact_pair {
  double hi, lo;
};

exact_pair two_sum(double a, double b) {
  const double sum = a + b;
  const double b_part = sum - a;
  const double a_part = sum - b_part;
  return {sum, (a - a_part) + (b - b_part)};
}

exact_pair two_difference(double a, double b) { return two_sum(a, -b); }

exact_pair two_product(double a, double b) {
  const double product = a * b;
  return {product, std::fma(a, b, -product)};  // fma is exact here: a·b − product fits in one double
}

/// An exact running sum of doubles, kept as a nonoverlapping expansion in increasing magnitude (Shewchuk's
/// Grow-Expansion with zero elimination). Adding n values never needs more than n components.
template <std::size_t capacity>
class exact_sum {
 public:
  void add(double value) {
    double carry = value;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < size_; ++i) {
      const exact_pair step = two_sum(carry, components_[i]);
      carry = step.hi;
      if (step.lo != 0) components_[kept++] = step.lo;
    }
    if (carry != 0 && kept < capacity) components_[kept++] = carry;
    size_ = kept;
  }

  /// The largest component of a nonoverlapping expansion carries the sign of the whole sum.
  int sign() const {
    if (size_ == 0) return 0;
    return components_[size_ - 1] > 0 ? 1 : -1;
  }

 private:
  std::array<double, capacity> components_{};
  std::size_t size_ = 0;
};

/// Adds sign · x · y exactly, where x, y are doubles (two terms).
template <std::size_t capacity>
void add_product(exact_sum<capacity>& sum, double x, double y, double sign) {
  const exact_pair product = two_product(x, y);
  sum.add(sign * product.hi);
  sum.add(sign * product.lo);
}

/// Adds sign · x · y · z exactly, where x, y, z are exact pairs (up to 8 · 4 terms).
template <std::size_t capacity>
void add_triple_product(exact_sum<capacity>& sum, const exact_pair& x, const exact_pair& y, const exact_pair& z,
                        double sign) {
  for (const double xi : {x.hi, x.lo}) {
    for (const double yi : {y.hi, y.lo}) {
      if (xi == 0 || yi == 0) continue;
      const exact_pair xy = two_product(xi, yi);
      for (const double zi : {z.hi, z.lo}) {
        if (zi == 0) continue;
        add_product(sum, xy.hi, zi, sign);
        add_product(sum, xy.lo, zi, sign);
      }
    }
  }
}

using exact_row = std::array<exact_pair, 3>;

exact_row exact_difference(const vec3& p, const vec3& origin) {
  return {two_difference(p.x, origin.x), two_difference(p.y, origin.y), two_difference(p.z, origin.z)};
}

int orient3d_exact(const vec3& a, const vec3& b, const vec3& c, const vec3& p) {
  const std::array<exact_row, 3> rows = {exact_difference(b, a), exact_difference(c, a), exact_difference(p, a)};
  // Leibniz expansion: det = Σ_σ sign(σ) · rows[0][σ0] · rows[1][σ1] · rows[2][σ2].
  struct permutation {
    int column[3];
    double sign;
  };
  static constexpr permutation permutations[6] = {{{0, 1, 2}, 1.0},  {{1, 2, 0}, 1.0},  {{2, 0, 1}, 1.0},
                                                  {{0, 2, 1}, -1.0}, {{1, 0, 2}, -1.0}, {{2, 1, 0}, -1.0}};
  exact_sum<6 * 8 * 4> sum;
  for (const permutation& sigma : permutations) {
    add_triple_product(sum, rows[0][sigma.column[0]], rows[1][sigma.column[1]], rows[2][sigma.column[2]], sigma.sign);
  }
  return sum.sign();
}

int orient2d_exact(double ax, double ay, double bx, double by, double cx, double cy) {
  const exact_pair bax = two_difference(bx, ax), bay = two_difference(by, ay);
  const exact_pair cax = two_difference(cx, ax), cay = two_difference(cy, ay);
  exact_sum<2 * 4 * 2> sum;
  for (const double u : {bax.hi, bax.lo}) {
    for (const double v : {cay.hi, cay.lo}) add_product(sum, u, v, 1.0);
  }
  for (const double u : {bay.hi, bay.lo}) {
    for (const double v : {cax.hi, cax.lo}) add_product(sum, u, v, -1.0);
  }
  return sum.sign();
}

}  // namespace

int orient3d(const vec3& a, const vec3& b, const vec3& c, const vec3& p) {
  const double bax = b.x - a.x, bay = b.y - a.y, baz = b.z - a.z;
  const double cax = c.x - a.x, cay = c.y - a.y, caz = c.z - a.z;
  const double pax = p.x - a.x, pay = p.y - a.y, paz = p.z - a.z;
  const double minor_x = cay * paz - caz * pay;
  const double minor_y = caz * pax - cax * paz;
  const double minor_z = cax * pay - cay * pax;
  const double determinant = bax * minor_x + bay * minor_y + baz * minor_z;
  const double permanent = std::abs(bax) * (std::abs(cay * paz) + std::abs(caz * pay)) +
                           std::abs(bay) * (std::abs(caz * pax) + std::abs(cax * paz)) +
                           std::abs(baz) * (std::abs(cax * pay) + std::abs(cay * pax));
  const double bound = orient3d_error_bound * permanent;
  if (determinant > bound) return 1;
  if (determinant < -bound) return -1;
  return orient3d_exact(a, b, c, p);
}

int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  const double left = (bx - ax) * (cy - ay);
  const double right = (by - ay) * (cx - ax);
  const double determinant = left - right;
  const double bound = orient2d_error_bound * (std::abs(left) + std::abs(right));
  if (determinant > bound) return 1;
  if (determinant < -bound) return -1;
  return orient2d_exact(ax, ay, bx, by, cx, cy);
}

}  // namespace tracemesh::detail
