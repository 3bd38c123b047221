#pragma once
/// @file separable_kernel.hpp
/// The two loops of the separable kernel (paper §1: exp(d|x−c|²/r²) is a product of three 1-D factors) that the
/// lattice sampler and the line roots share: one atom's 1-D factors along an axis, and its terms added to a row of
/// sums. One copy of each, so a lattice point and a line node get their terms with the same roundings.

#include "core/field/gaussian_field.hpp"

namespace tracemesh::simd {

/// 1-D kernel factors exp(d·δ²/r²) and δ² = (coordinate − centre)² for `count` coordinates (a multiple of W).
template <int W>
[[gnu::always_inline]] inline void axis_factors(const double* coordinate, int count, double centre, double d,
                                                double inv_r2, double* squared, double* factor) {
  using F = typename pack<W>::f64;
  for (int m = 0; m < count; m += W) {
    F delta;
    load(delta, coordinate + m);
    delta -= centre;
    const F delta2 = delta * delta;
    F e = d * delta2 * inv_r2;
    exp_in_place(e);
    store(squared + m, delta2);
    store(factor + m, e);
  }
}

/// sums[m] += factor[m]·weight for the m ∈ [begin, end) within the atom's cutoff (offset2[m] + rho2 < cutoff2),
/// W entries at a time and the rest one by one. Masked-out entries add +0, which leaves their (non-negative) sums
/// unchanged, and the product is masked before the sum, so it is never fused with it: every entry gets the same
/// roundings whichever lane, width or caller computes it.
template <int W>
[[gnu::always_inline]] inline void add_kernel_terms(double* sums, const double* factor, const double* offset2,
                                                    double weight, double rho2, double cutoff2, int begin, int end) {
  using F = typename pack<W>::f64;
  int m = begin;
  for (; m + W <= end; m += W) {
    F sum, e, q2;
    load(sum, sums + m);
    load(e, factor + m);
    load(q2, offset2 + m);
    F term = e * weight;
    keep_lanes(term, q2 + rho2 < cutoff2);
    sum += term;
    store(sums + m, sum);
  }
  for (; m < end; ++m) {
    double term = factor[m] * weight;
    keep_if(term, offset2[m] + rho2 < cutoff2);
    sums[m] += term;
  }
}

}  // namespace tracemesh::simd
