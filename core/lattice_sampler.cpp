#include "core/lattice_sampler.hpp"

#include <array>
#include <cmath>

namespace tracemesh {

void sample_block(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                  std::span<const std::uint32_t> atoms, std::vector<double>& values) {
  constexpr int n = block_points;
  values.assign(static_cast<std::size_t>(n) * n * n, 0.0);
  const double h = lat.spacing();
  const double d = field.d();
  const double scale = std::exp(-d);
  const lattice_index first{block.i * lattice::block_cells, block.j * lattice::block_cells,
                            block.k * lattice::block_cells};
  std::array<double, n> ex{}, ey{}, ez{}, dx2{}, dy2{}, dz2{};
  for (const std::uint32_t k : atoms) {
    const auto& a = field.atom_at(k);
    for (int m = 0; m < n; ++m) {
      // Coordinates from global indices: identical doubles in every block that holds the point.
      const double dx = static_cast<double>(first.i + m) * h - a.x;
      const double dy = static_cast<double>(first.j + m) * h - a.y;
      const double dz = static_cast<double>(first.k + m) * h - a.z;
      dx2[m] = dx * dx;
      dy2[m] = dy * dy;
      dz2[m] = dz * dz;
      ex[m] = std::exp(d * dx2[m] * a.inv_r2);
      ey[m] = std::exp(d * dy2[m] * a.inv_r2);
      ez[m] = std::exp(d * dz2[m] * a.inv_r2);
    }
    for (int z = 0; z < n; ++z) {
      if (dz2[z] >= a.cutoff2) continue;
      for (int y = 0; y < n; ++y) {
        const double yz2 = dy2[y] + dz2[z];
        if (yz2 >= a.cutoff2) continue;
        const double eyz = scale * ey[y] * ez[z];
        double* row = values.data() + static_cast<std::size_t>(z * n + y) * n;
        for (int x = 0; x < n; ++x) {
          if (dx2[x] + yz2 < a.cutoff2) row[x] += ex[x] * eyz;
        }
      }
    }
  }
}

}  // namespace tracemesh
