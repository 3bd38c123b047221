#include "core/band_culling.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <tuple>

namespace tracemesh {
namespace {

/// Octree depth from top cubes to blocks: a top cube is 2^levels blocks on a side.
constexpr int octree_levels = 3;
constexpr std::int64_t top_blocks = 1 << octree_levels;

struct axis_factors {
  double lower, upper;
};

/// Extremes of exp(d (x − c)² / r²) for x ∈ [lo, hi] (eq. 4).
axis_factors kernel_extremes(double d, double inv_r2, double c, double lo, double hi) {
  const double at_lo = std::exp(d * (lo - c) * (lo - c) * inv_r2);
  const double at_hi = std::exp(d * (hi - c) * (hi - c) * inv_r2);
  const double upper = (c >= lo && c <= hi) ? 1.0 : std::max(at_lo, at_hi);
  return {std::min(at_lo, at_hi), upper};
}

double farthest_corner_squared(const box3& box, const vec3& c) {
  double sum = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double far = std::max(std::abs(box.lo[axis] - c[axis]), std::abs(box.hi[axis] - c[axis]));
    sum += far * far;
  }
  return sum;
}

/// Top-level cubes (in units of top cubes) reached by some atom's cutoff sphere.
std::vector<lattice_index> top_cubes(const gaussian_field& field, const lattice& lat) {
  const double top_size = lat.spacing() * lattice::block_cells * top_blocks;
  std::vector<lattice_index> cubes;
  for (std::uint32_t k = 0; k < field.atom_count(); ++k) {
    const auto& a = field.atom_at(k);
    const double reach = std::sqrt(a.cutoff2);
    const vec3 c{a.x, a.y, a.z};
    std::array<std::int64_t, 3> lo{}, hi{};
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = static_cast<std::int64_t>(std::floor((c[axis] - reach) / top_size));
      hi[axis] = static_cast<std::int64_t>(std::floor((c[axis] + reach) / top_size));
    }
    for (std::int64_t i = lo[0]; i <= hi[0]; ++i)
      for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
        for (std::int64_t kk = lo[2]; kk <= hi[2]; ++kk) cubes.push_back({i, j, kk});
  }
  const auto less = [](const lattice_index& a, const lattice_index& b) {
    return std::tie(a.i, a.j, a.k) < std::tie(b.i, b.j, b.k);
  };
  std::sort(cubes.begin(), cubes.end(), less);
  cubes.erase(std::unique(cubes.begin(), cubes.end()), cubes.end());
  return cubes;
}

/// Recursively refines the cube of `size` blocks whose lowest block is `corner`; appends surviving blocks.
void refine(const gaussian_field& field, const lattice& lat, const lattice_index& corner, std::int64_t size,
            std::span<const std::uint32_t> parent_atoms, std::vector<lattice_index>& blocks) {
  const box3 lo_box = lat.block_box(corner);
  const box3 hi_box = lat.block_box({corner.i + size - 1, corner.j + size - 1, corner.k + size - 1});
  const box3 box{lo_box.lo, hi_box.hi};
  std::vector<std::uint32_t> atoms;
  atoms.reserve(parent_atoms.size());
  for (const std::uint32_t k : parent_atoms) {
    const auto& a = field.atom_at(k);
    const double dx = std::max({box.lo.x - a.x, 0.0, a.x - box.hi.x});
    const double dy = std::max({box.lo.y - a.y, 0.0, a.y - box.hi.y});
    const double dz = std::max({box.lo.z - a.z, 0.0, a.z - box.hi.z});
    if (dx * dx + dy * dy + dz * dz < a.cutoff2) atoms.push_back(k);
  }
  if (atoms.empty()) return;  // φ ≡ 0 < t0 here
  if (bounds_exclude(bound_field_on_box(field, box, atoms), field.t0())) return;
  if (size == 1) {
    blocks.push_back(corner);
    return;
  }
  const std::int64_t half = size / 2;
  for (int octant = 0; octant < 8; ++octant) {
    const lattice_index child{corner.i + ((octant & 1) ? half : 0), corner.j + ((octant & 2) ? half : 0),
                              corner.k + ((octant & 4) ? half : 0)};
    refine(field, lat, child, half, atoms, blocks);
  }
}

}  // namespace

field_bounds bound_field_on_box(const gaussian_field& field, const box3& box, std::span<const std::uint32_t> atoms) {
  const double d = field.d();
  const double scale = std::exp(-d);  // e^(−d): the "− 1" of eq. 2
  field_bounds bounds;
  for (const std::uint32_t k : atoms) {
    const auto& a = field.atom_at(k);
    const axis_factors fx = kernel_extremes(d, a.inv_r2, a.x, box.lo.x, box.hi.x);
    const axis_factors fy = kernel_extremes(d, a.inv_r2, a.y, box.lo.y, box.hi.y);
    const axis_factors fz = kernel_extremes(d, a.inv_r2, a.z, box.lo.z, box.hi.z);
    bounds.upper += scale * fx.upper * fy.upper * fz.upper;
    if (farthest_corner_squared(box, {a.x, a.y, a.z}) < a.cutoff2) {
      bounds.lower += scale * fx.lower * fy.lower * fz.lower;
    }
  }
  return bounds;
}

bool bounds_exclude(const field_bounds& bounds, double t0) {
  constexpr double margin = 1e-9;
  return bounds.lower > t0 * (1 + margin) || bounds.upper < t0 * (1 - margin);
}

result<std::vector<lattice_index>> cull_blocks(const gaussian_field& field, const lattice& lat,
                                               progress_token& progress) {
  const std::vector<lattice_index> tops = top_cubes(field, lat);
  std::vector<std::vector<lattice_index>> per_top(tops.size());
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(std::size_t{0}, tops.size(), [&](std::size_t n) {
    if (progress.cancelled()) return;
    const lattice_index corner{tops[n].i * top_blocks, tops[n].j * top_blocks, tops[n].k * top_blocks};
    const box3 lo_box = lat.block_box(corner);
    const box3 hi_box = lat.block_box({corner.i + top_blocks - 1, corner.j + top_blocks - 1, corner.k + top_blocks - 1});
    std::vector<std::uint32_t> atoms;
    field.atoms_near_box({lo_box.lo, hi_box.hi}, atoms);
    refine(field, lat, corner, top_blocks, atoms, per_top[n]);
    const std::size_t finished = ++done;
    if (finished % 64 == 0) progress.report(mesh_stage::culling, static_cast<double>(finished) / tops.size());
  });
  if (progress.cancelled()) return status{errc::cancelled, "cancelled"};
  std::vector<lattice_index> blocks;
  for (auto& list : per_top) blocks.insert(blocks.end(), list.begin(), list.end());
  std::sort(blocks.begin(), blocks.end(), [](const lattice_index& a, const lattice_index& b) {
    return std::tie(a.i, a.j, a.k) < std::tie(b.i, b.j, b.k);
  });
  return blocks;
}

}  // namespace tracemesh
