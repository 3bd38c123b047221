#include "core/lattice/lattice_sampler.hpp"

#include <array>

namespace tracemesh {
namespace {

/// block_points rounded up to whole vectors of the widest width: per-axis arrays are computed W lanes at a time.
constexpr int padded_points = (block_points + simd::max_lanes - 1) / simd::max_lanes * simd::max_lanes;
using axis_array = std::array<double, padded_points>;

/// Lattice coordinates (Å) of the block's points along one axis, from global indices: identical doubles in every
/// block that holds the point.
axis_array axis_coordinates(std::int64_t first_index, double h) {
  axis_array coordinate{};
  for (int m = 0; m < padded_points; ++m) coordinate[m] = static_cast<double>(first_index + m) * h;
  return coordinate;
}

/// Squared distances (x − c)² from the atom's centre along one axis, and the 1-D kernel factors exp(d·(x − c)²/r²).
template <int W>
[[gnu::always_inline]] inline void axis_factors(const axis_array& coordinate, double centre, double d, double inv_r2,
                                                axis_array& squared, axis_array& factor) {
  using F = typename simd::pack<W>::f64;
  for (int m = 0; m < padded_points; m += W) {
    F delta;
    simd::load(delta, coordinate.data() + m);
    delta -= centre;
    const F delta2 = delta * delta;
    F e = d * delta2 * inv_r2;
    simd::exp_in_place(e);
    simd::store(squared.data() + m, delta2);
    simd::store(factor.data() + m, e);
  }
}

/// row[x] += ex[x]·eyz for the points of one lattice row within the atom's cutoff (dx²[x] + yz² < cutoff²), W
/// points at a time and the rest one by one. Masked-out points add +0, which leaves their (non-negative) sums
/// unchanged, and the product is masked before the sum, so it is never fused with it: every point gets the same
/// roundings whichever lane or block computes it.
template <int W>
[[gnu::always_inline]] inline void add_row(double* row, const axis_array& ex, const axis_array& dx2, double eyz,
                                           double yz2, double cutoff2) {
  using F = typename simd::pack<W>::f64;
  int x = 0;
  for (; x + W <= block_points; x += W) {
    F sum, factor, distance2;
    simd::load(sum, row + x);
    simd::load(factor, ex.data() + x);
    simd::load(distance2, dx2.data() + x);
    F term = factor * eyz;
    simd::keep_lanes(term, distance2 + yz2 < cutoff2);
    sum += term;
    simd::store(row + x, sum);
  }
  for (; x < block_points; ++x) {
    double term = ex[x] * eyz;
    simd::keep_if(term, dx2[x] + yz2 < cutoff2);
    row[x] += term;
  }
}

template <int W>
[[gnu::always_inline]] inline void sample_block_lanes(const gaussian_field& field, const lattice& lat,
                                                      const lattice_index& block, std::span<const std::uint32_t> atoms,
                                                      std::vector<double>& values) {
  constexpr int n = block_points;
  const double h = lat.spacing();
  const double d = field.d();
  const double scale = kernel_exp(-d);  // e^(−d): the "− 1" of eq. 2
  const axis_array x_coordinate = axis_coordinates(block.i * lattice::block_cells, h);
  const axis_array y_coordinate = axis_coordinates(block.j * lattice::block_cells, h);
  const axis_array z_coordinate = axis_coordinates(block.k * lattice::block_cells, h);
  const gaussian_field::atom_arrays all = field.atoms();
  axis_array ex, ey, ez, dx2, dy2, dz2;
  for (const std::uint32_t k : atoms) {
    const double inv_r2 = all.inv_r2[k], cutoff2 = all.cutoff2[k];
    axis_factors<W>(x_coordinate, all.x[k], d, inv_r2, dx2, ex);
    axis_factors<W>(y_coordinate, all.y[k], d, inv_r2, dy2, ey);
    axis_factors<W>(z_coordinate, all.z[k], d, inv_r2, dz2, ez);
    for (int z = 0; z < n; ++z) {
      if (dz2[z] >= cutoff2) continue;
      for (int y = 0; y < n; ++y) {
        const double yz2 = dy2[y] + dz2[z];
        if (yz2 >= cutoff2) continue;
        add_row<W>(values.data() + static_cast<std::size_t>(z * n + y) * n, ex, dx2, scale * ey[y] * ez[z], yz2,
                   cutoff2);
      }
    }
  }
}

}  // namespace

void sample_block(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                  std::span<const std::uint32_t> atoms, std::vector<double>& values) {
  values.assign(static_cast<std::size_t>(block_points) * block_points * block_points, 0.0);
  simd::dispatch([&](auto lanes) __attribute__((always_inline)) {
    sample_block_lanes<decltype(lanes)::value>(field, lat, block, atoms, values);
  });
}

}  // namespace tracemesh
