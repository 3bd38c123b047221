#include "core/lattice/lattice_sampler.hpp"

#include <array>

#include "core/field/separable_kernel.hpp"

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
    simd::axis_factors<W>(x_coordinate.data(), padded_points, all.x[k], d, inv_r2, dx2.data(), ex.data());
    simd::axis_factors<W>(y_coordinate.data(), padded_points, all.y[k], d, inv_r2, dy2.data(), ey.data());
    simd::axis_factors<W>(z_coordinate.data(), padded_points, all.z[k], d, inv_r2, dz2.data(), ez.data());
    for (int z = 0; z < n; ++z) {
      if (dz2[z] >= cutoff2) continue;
      for (int y = 0; y < n; ++y) {
        const double yz2 = dy2[y] + dz2[z];
        if (yz2 >= cutoff2) continue;
        simd::add_kernel_terms<W>(values.data() + static_cast<std::size_t>(z * n + y) * n, ex.data(), dx2.data(),
                                  scale * ey[y] * ez[z], yz2, cutoff2, 0, n);
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
