#include "core/field/band_culling.hpp"

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

/// Atoms as parallel arrays (x, y, z, d/r², cutoff²), padded with never-contributing entries (cutoff² = 0) to whole
/// vectors. One per octree level: a cube's atoms are those of its parent whose cutoff sphere reaches it.
struct atom_columns {
  std::vector<double> x, y, z, d_inv_r2, cutoff2;
  std::size_t count = 0;

  void reserve_padded(std::size_t n) {
    const std::size_t padded = (n + simd::max_lanes - 1) / simd::max_lanes * simd::max_lanes;
    for (auto* column : {&x, &y, &z, &d_inv_r2, &cutoff2}) column->resize(padded);
  }
  void push_back(double ax, double ay, double az, double a_d_inv_r2, double a_cutoff2) {
    x[count] = ax;
    y[count] = ay;
    z[count] = az;
    d_inv_r2[count] = a_d_inv_r2;
    cutoff2[count] = a_cutoff2;
    ++count;
  }
  /// Zeroes cutoff² of the padding after the last atom.
  void finish_padding() {
    for (std::size_t k = count; k < cutoff2.size(); ++k) cutoff2[k] = 0;
  }
};

void gather_columns(const gaussian_field& field, std::span<const std::uint32_t> atoms, atom_columns& out) {
  out.count = 0;
  out.reserve_padded(atoms.size());
  const gaussian_field::atom_arrays all = field.atoms();
  for (const std::uint32_t k : atoms) out.push_back(all.x[k], all.y[k], all.z[k], field.d() * all.inv_r2[k], all.cutoff2[k]);
  out.finish_padding();
}

/// Per lane: the distance from c to the interval [lo, hi] (0 inside it) in `near`, to its farther end in `far`.
template <class F>
[[gnu::always_inline]] inline void interval_distances(const F& c, double lo, double hi, F& near, F& far) {
  using M = simd::mask_of<F>;
  const F below = lo - c, above = c - hi;  // at most one is positive
  const M use_below = below > 0.0, use_above = above > 0.0;
  near = reinterpret_cast<F>((reinterpret_cast<M>(below) & use_below) | (reinterpret_cast<M>(above) & use_above));
  constexpr std::int64_t magnitude = 0x7fffffffffffffffLL;  // all bits but the sign
  const F abs_lo = reinterpret_cast<F>(reinterpret_cast<M>(c - lo) & magnitude);
  const F abs_hi = reinterpret_cast<F>(reinterpret_cast<M>(hi - c) & magnitude);
  const M lo_farther = abs_lo > abs_hi;
  far = reinterpret_cast<F>((reinterpret_cast<M>(abs_lo) & lo_farther) | (reinterpret_cast<M>(abs_hi) & ~lo_farther));
}

/// Bounds of the cut-off field on `box` from `atoms` (eqs. 4–5): per atom, the kernel is largest at the point of the
/// box nearest its centre and smallest at the farthest corner; exp(a)·exp(b)·exp(c) = exp(a + b + c), so each
/// product of per-axis extremes is one exponential. An atom adds to `lower` only when its cutoff sphere holds the
/// whole box. When `reaching` is given, the atoms whose cutoff sphere reaches the box are appended to it.
template <int W>
[[gnu::always_inline]] inline field_bounds bound_box(const atom_columns& atoms, const box3& box, double scale,
                                                     atom_columns* reaching) {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  F upper{}, lower{};
  for (std::size_t k = 0; k < atoms.count; k += W) {
    F cx, cy, cz, d_inv_r2, cutoff2;
    simd::load(cx, atoms.x.data() + k);
    simd::load(cy, atoms.y.data() + k);
    simd::load(cz, atoms.z.data() + k);
    simd::load(d_inv_r2, atoms.d_inv_r2.data() + k);
    simd::load(cutoff2, atoms.cutoff2.data() + k);
    F near_x, near_y, near_z, far_x, far_y, far_z;
    interval_distances(cx, box.lo.x, box.hi.x, near_x, far_x);
    interval_distances(cy, box.lo.y, box.hi.y, near_y, far_y);
    interval_distances(cz, box.lo.z, box.hi.z, near_z, far_z);
    const F near2 = near_x * near_x + near_y * near_y + near_z * near_z;
    const F far2 = far_x * far_x + far_y * far_y + far_z * far_z;
    const M reaches = near2 < cutoff2, contains = far2 < cutoff2;  // padding: cutoff² = 0, neither
    if (!simd::any_lane(reaches)) continue;
    F largest = d_inv_r2 * near2, smallest = d_inv_r2 * far2;
    simd::exp_in_place(largest);
    simd::exp_in_place(smallest);
    simd::keep_lanes(largest, reaches);
    simd::keep_lanes(smallest, contains);
    upper += largest;
    lower += smallest;
    if (reaching == nullptr) continue;
    for (int j = 0; j < W; ++j) {
      if (reaches[j]) reaching->push_back(cx[j], cy[j], cz[j], d_inv_r2[j], cutoff2[j]);
    }
  }
  if (reaching != nullptr) reaching->finish_padding();
  return {scale * simd::lane_sum(lower), scale * simd::lane_sum(upper)};
}

/// Top-level cubes (in units of top cubes) reached by some atom's cutoff sphere.
std::vector<lattice_index> top_cubes(const gaussian_field& field, const lattice& lat) {
  const double top_size = lat.spacing() * lattice::block_cells * top_blocks;
  std::vector<lattice_index> cubes;
  for (std::uint32_t k = 0; k < field.atom_count(); ++k) {
    const auto a = field.atom_at(k);
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

/// One cube of the octree to visit: its lowest block, its size in blocks and its depth (0 for top cubes).
struct octree_cube {
  lattice_index corner;
  std::int64_t size;
  int depth;
};

/// The octree below top cubes, depth first with an explicit stack (so that it all compiles into one vectorised
/// function). A cube's atoms are those of its parent whose cutoff sphere reaches it; atoms[depth] holds them for the
/// cube being refined at that depth and stays valid while its children are visited.
class octree_refiner {
 public:
  octree_refiner(const gaussian_field& field, const lattice& lat)
      : lat_(lat), t0_(field.t0()), scale_(kernel_exp(-field.d())), atoms_(octree_levels + 2) {}

  /// Scratch for the atoms reaching a top cube, to be filled before refine_top().
  atom_columns& top_atoms() { return atoms_[0]; }

  /// Appends the blocks of the top cube at `corner` (in blocks) that may hold surface.
  template <int W>
  [[gnu::always_inline]] void refine_top(const lattice_index& corner, std::vector<lattice_index>& blocks) {
    stack_.assign(1, {corner, top_blocks, 0});
    while (!stack_.empty()) {
      const octree_cube cube = stack_.back();
      stack_.pop_back();
      const box3 lo_box = lat_.block_box(cube.corner);
      const box3 hi_box =
          lat_.block_box({cube.corner.i + cube.size - 1, cube.corner.j + cube.size - 1, cube.corner.k + cube.size - 1});
      atom_columns& reaching = atoms_[cube.depth + 1];
      reaching.count = 0;
      reaching.reserve_padded(atoms_[cube.depth].count);
      const field_bounds bounds =
          bound_box<W>(atoms_[cube.depth], {lo_box.lo, hi_box.hi}, scale_, cube.size > 1 ? &reaching : nullptr);
      if (bounds.upper == 0) continue;  // no atom reaches the cube: φ ≡ 0 < t0 here
      if (bounds_exclude(bounds, t0_)) continue;
      if (cube.size == 1) {
        blocks.push_back(cube.corner);
        continue;
      }
      const std::int64_t half = cube.size / 2;
      for (int octant = 7; octant >= 0; --octant) {  // pushed in reverse: visited in octant order
        const lattice_index child{cube.corner.i + ((octant & 1) ? half : 0), cube.corner.j + ((octant & 2) ? half : 0),
                                  cube.corner.k + ((octant & 4) ? half : 0)};
        stack_.push_back({child, half, cube.depth + 1});
      }
    }
  }

 private:
  const lattice& lat_;
  double t0_, scale_;
  std::vector<atom_columns> atoms_;  ///< atoms_[0]: the top cube's candidates; atoms_[d + 1]: those reaching the cube at depth d
  std::vector<octree_cube> stack_;
};

}  // namespace

field_bounds bound_field_on_box(const gaussian_field& field, const box3& box, std::span<const std::uint32_t> atoms) {
  atom_columns columns;
  gather_columns(field, atoms, columns);
  return simd::dispatch([&](auto lanes) __attribute__((always_inline)) {
    return bound_box<decltype(lanes)::value>(columns, box, kernel_exp(-field.d()), nullptr);
  });
}

bool bounds_exclude(const field_bounds& bounds, double t0) {
  constexpr double margin = 1e-9;
  return bounds.lower > t0 * (1 + margin) || bounds.upper < t0 * (1 - margin);
}

namespace {

/// Refines the top cubes [begin, end) into `per_top`.
void refine_top_cubes(const gaussian_field& field, const lattice& lat, const std::vector<lattice_index>& tops,
                      std::size_t begin, std::size_t end, std::vector<std::vector<lattice_index>>& per_top,
                      progress_token& progress, std::atomic<std::size_t>& done) {
  octree_refiner refiner(field, lat);
  std::vector<std::uint32_t> atom_indices;
  for (std::size_t n = begin; n < end; ++n) {
    if (progress.cancelled()) return;
    const lattice_index corner{tops[n].i * top_blocks, tops[n].j * top_blocks, tops[n].k * top_blocks};
    const box3 lo_box = lat.block_box(corner);
    const box3 hi_box = lat.block_box({corner.i + top_blocks - 1, corner.j + top_blocks - 1, corner.k + top_blocks - 1});
    field.atoms_near_box({lo_box.lo, hi_box.hi}, atom_indices);
    gather_columns(field, atom_indices, refiner.top_atoms());
    simd::dispatch([&](auto lanes) __attribute__((always_inline)) {
      refiner.refine_top<decltype(lanes)::value>(corner, per_top[n]);
    });
    const std::size_t finished = ++done;
    if (finished % 64 == 0) progress.report(mesh_stage::culling, static_cast<double>(finished) / tops.size());
  }
}

}  // namespace

result<std::vector<lattice_index>> cull_blocks(const gaussian_field& field, const lattice& lat,
                                               progress_token& progress) {
  const std::vector<lattice_index> tops = top_cubes(field, lat);
  std::vector<std::vector<lattice_index>> per_top(tops.size());
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tops.size()), [&](const tbb::blocked_range<std::size_t>& r) {
    refine_top_cubes(field, lat, tops, r.begin(), r.end(), per_top, progress, done);
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
