#include "core/field/gaussian_field.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

namespace tracemesh {
namespace {


/// ∫_U^∞ u² e^(−a u²) du for a > 0 (integration by parts + erfc).
double gaussian_moment_tail(double a, double u) {
  return u * std::exp(-a * u * u) / (2 * a) + std::sqrt(M_PI) / (4 * a * std::sqrt(a)) * std::erfc(std::sqrt(a) * u);
}

/// Neglected φ beyond cutoff factor u: the kernel's tail integrated over a uniform density of atom centres.
double tail_bound(double d, double max_radius, double u) {
  const double a = -d;
  return max_atom_number_density * 4 * M_PI * max_radius * max_radius * max_radius * std::exp(a) *
         gaussian_moment_tail(a, u);
}

/// Cells are largest cutoff / row_reach wide in x and y and largest cutoff / z_reach high. A query visits the cell
/// rows (x, y) that its cutoff sphere reaches, each trimmed in z to the sphere: wide rows are few (at most 9 here),
/// and short cells trim them closely. Measured on mache against cubes of a third of the cutoff: 30% faster.
constexpr int row_reach = 1;
constexpr int z_reach = 8;
/// The dense cell table is used while the atoms' bounding box holds at most this many cells per atom plus
/// dense_cells_floor (4 bytes each: memory stays O(atoms)); sparser inputs use hashed rows.
constexpr double dense_cells_per_atom = 4;
constexpr double dense_cells_floor = 1 << 22;

/// Lanes of a point evaluation: about 60 atoms per point, gathered one by one into the lanes; measured on AVX-512,
/// 8 lanes are 20-50% slower than 4.
constexpr int point_lanes = 4;

/// Relative slack on cutoffs when selecting cells or boxes, so that rounding never drops an atom the exact per-atom
/// test (r² < cutoff²) would keep. Selecting a few extra atoms changes nothing: they fail that test.
constexpr double selection_slack = 1e-9;

/// The cutoff grown by the selection slack, relative to itself and to the coordinates' magnitude (rounding in
/// cell_of and in the gaps grows with |coordinates|).
double selection_reach(double cutoff, double magnitude) {
  return cutoff * (1 + selection_slack) + selection_slack * magnitude;
}

/// splitmix64 finaliser: spreads packed row keys over the hash table.
std::uint64_t mix(std::uint64_t key) {
  key ^= key >> 30;
  key *= 0xbf58476d1ce4e5b9ULL;
  key ^= key >> 27;
  key *= 0x94d049bb133111ebULL;
  return key ^ (key >> 31);
}

/// Per-lane running sums of one point evaluation, and the best kernel so far for the dominant atom.
template <int W>
struct lane_sums {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  F value{};
  F gx{}, gy{}, gz{};
  F best_kernel = F{} - 1.0;
  M best_index = M{} - 1;
};

}  // namespace

double cutoff_factor(double d, double t0, double max_radius, double tolerance) {
  const double target = tolerance * t0;
  double lo = 1.0, hi = 1.0;
  while (tail_bound(d, max_radius, hi) > target && hi < 1e3) hi *= 2;
  for (int i = 0; i < 60; ++i) {  // bisection on a monotone function
    const double mid = 0.5 * (lo + hi);
    (tail_bound(d, max_radius, mid) > target ? lo : hi) = mid;
  }
  return hi;
}

gaussian_field::gaussian_field(const molecule& mol, double d, double t0, double tolerance) : d_(d), t0_(t0) {
  std::vector<std::uint32_t> contributing;
  contributing.reserve(mol.atoms.size());
  for (std::uint32_t i = 0; i < mol.atoms.size(); ++i) {
    if (mol.atoms[i].radius > 0) {
      contributing.push_back(i);
      max_radius_ = std::max(max_radius_, mol.atoms[i].radius);
    }
  }
  if (contributing.empty()) {
    store_atoms(mol, contributing, contributing, 0);
    return;
  }
  const double u = cutoff_factor(d, t0, max_radius_, tolerance);
  cutoff_error_bound_ = tail_bound(d, max_radius_, u);
  max_cutoff_ = u * max_radius_;
  for (int axis = 0; axis < 3; ++axis) {
    cell_size_[axis] = max_cutoff_ / (axis == 2 ? z_reach : row_reach);
    inverse_cell_size_[axis] = 1 / cell_size_[axis];
  }

  atom_bounds_ = box3::around(mol.atoms[contributing.front()].center);
  for (const std::uint32_t i : contributing) atom_bounds_.include(mol.atoms[i].center);
  sort_atoms(mol, contributing, u);
}

void gaussian_field::sort_atoms(const molecule& mol, const std::vector<std::uint32_t>& contributing, double u) {
  // Cell coordinates of every atom, three per atom.
  std::vector<std::int64_t> cells(3 * contributing.size());
  for (std::size_t n = 0; n < contributing.size(); ++n) {
    const vec3& c = mol.atoms[contributing[n]].center;
    for (int axis = 0; axis < 3; ++axis) cells[3 * n + axis] = cell_of(c[axis], axis);
  }
  double cell_total = 1;
  for (int axis = 0; axis < 3; ++axis) {
    cell_lo_[axis] = cell_of(atom_bounds_.lo[axis], axis);
    cell_count_[axis] = cell_of(atom_bounds_.hi[axis], axis) - cell_lo_[axis] + 1;
    cell_total *= static_cast<double>(cell_count_[axis]);
  }
  dense_ = cell_total <= dense_cells_per_atom * static_cast<double>(contributing.size()) + dense_cells_floor;
  std::vector<std::uint32_t> order;  // positions in `contributing`, in internal order
  if (dense_) {
    build_dense_index(cells, order);
  } else {
    build_sparse_index(cells, order);
  }
  store_atoms(mol, contributing, order, u);
}

void gaussian_field::build_dense_index(std::vector<std::int64_t>& cells, std::vector<std::uint32_t>& order) {
  // Counting sort by linear cell id; stable, so atoms within a cell keep their original order.
  const std::size_t count = cells.size() / 3;
  const auto [nx, ny, nz] = cell_count_;
  std::vector<std::uint32_t> cell_of_atom(count);
  cell_start_.assign(static_cast<std::size_t>(nx * ny * nz) + 1, 0);
  for (std::size_t n = 0; n < count; ++n) {
    const std::int64_t x = cells[3 * n] - cell_lo_[0], y = cells[3 * n + 1] - cell_lo_[1];
    const std::int64_t z = cells[3 * n + 2] - cell_lo_[2];
    cell_of_atom[n] = static_cast<std::uint32_t>((x * ny + y) * nz + z);
    ++cell_start_[cell_of_atom[n] + 1];
  }
  std::partial_sum(cell_start_.begin(), cell_start_.end(), cell_start_.begin());
  std::vector<std::uint32_t> next(cell_start_.begin(), cell_start_.end() - 1);
  order.resize(count);
  for (std::size_t n = 0; n < count; ++n) order[next[cell_of_atom[n]]++] = static_cast<std::uint32_t>(n);
}

void gaussian_field::build_sparse_index(std::vector<std::int64_t>& cells, std::vector<std::uint32_t>& order) {
  const std::size_t count = cells.size() / 3;
  order.resize(count);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return std::lexicographical_compare(&cells[3 * a], &cells[3 * a + 3], &cells[3 * b], &cells[3 * b + 3]);
  });
  cell_z_.resize(count);
  std::size_t capacity = 16;
  while (capacity < 2 * count) capacity *= 2;
  rows_.assign(capacity, sparse_row{});
  for (std::uint32_t k = 0; k < count;) {
    const std::int64_t cx = cells[3 * order[k]], cy = cells[3 * order[k] + 1];
    std::uint32_t end = k;
    while (end < count && cells[3 * order[end]] == cx && cells[3 * order[end] + 1] == cy) {
      cell_z_[end] = cells[3 * order[end] + 2];
      ++end;
    }
    const std::uint64_t key = row_key(cx, cy);
    std::size_t slot = mix(key) & (capacity - 1);
    while (rows_[slot].key != empty_row) slot = (slot + 1) & (capacity - 1);
    rows_[slot] = {key, {k, end}};
    k = end;
  }
}

void gaussian_field::store_atoms(const molecule& mol, const std::vector<std::uint32_t>& contributing,
                                 const std::vector<std::uint32_t>& order, double u) {
  const std::size_t padded = order.size() + simd::max_lanes - 1;
  for (auto* array : {&x_, &y_, &z_, &inv_r2_, &cutoff2_}) array->assign(padded, 0.0);
  original_index_.resize(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::uint32_t i = contributing[order[k]];
    const atom& a = mol.atoms[i];
    const double cutoff = u * a.radius;
    x_[k] = a.center.x;
    y_[k] = a.center.y;
    z_[k] = a.center.z;
    inv_r2_[k] = 1.0 / (a.radius * a.radius);
    cutoff2_[k] = cutoff * cutoff;
    original_index_[k] = i;
  }
}

std::int64_t gaussian_field::cell_of(double coordinate, int axis) const {
  return static_cast<std::int64_t>(std::floor(coordinate * inverse_cell_size_[axis]));
}

std::uint64_t gaussian_field::row_key(std::int64_t cx, std::int64_t cy) {
  return (static_cast<std::uint64_t>(cx + (1LL << 31)) << 32) ^ static_cast<std::uint64_t>(cy + (1LL << 31));
}

[[gnu::always_inline]] inline gaussian_field::atom_range gaussian_field::row_atoms(std::int64_t cx, std::int64_t cy,
                                                                                  std::int64_t z0,
                                                                                  std::int64_t z1) const {
  if (dense_) {
    const std::int64_t x = cx - cell_lo_[0], y = cy - cell_lo_[1];
    if (x < 0 || x >= cell_count_[0] || y < 0 || y >= cell_count_[1]) return {};
    z0 = std::max<std::int64_t>(z0 - cell_lo_[2], 0);
    z1 = std::min<std::int64_t>(z1 - cell_lo_[2], cell_count_[2] - 1);
    if (z0 > z1) return {};
    const std::size_t row = static_cast<std::size_t>((x * cell_count_[1] + y) * cell_count_[2]);
    return {cell_start_[row + static_cast<std::size_t>(z0)], cell_start_[row + static_cast<std::size_t>(z1) + 1]};
  }
  if (rows_.empty()) return {};
  const std::uint64_t key = row_key(cx, cy);
  const std::size_t mask = rows_.size() - 1;
  for (std::size_t slot = mix(key) & mask;; slot = (slot + 1) & mask) {
    const sparse_row& row = rows_[slot];
    if (row.key == empty_row) return {};
    if (row.key != key) continue;
    const auto first = cell_z_.begin() + row.atoms.begin, last = cell_z_.begin() + row.atoms.end;
    const auto lo = std::lower_bound(first, last, z0);
    const auto hi = std::upper_bound(lo, last, z1);
    return {static_cast<std::uint32_t>(lo - cell_z_.begin()), static_cast<std::uint32_t>(hi - cell_z_.begin())};
  }
}

template <class Visitor>
[[gnu::always_inline]] inline void gaussian_field::for_each_nearby_range(const vec3& p, Visitor&& visit) const {
  const double reach = selection_reach(max_cutoff_, std::abs(p.x) + std::abs(p.y) + std::abs(p.z));
  const double reach2 = reach * reach;
  const double c = cell_size_[0];  // = cell_size_[1]
  std::int64_t x0 = cell_of(p.x - reach, 0), x1 = cell_of(p.x + reach, 0);
  std::int64_t y0 = cell_of(p.y - reach, 1), y1 = cell_of(p.y + reach, 1);
  if (dense_) {  // rows outside the table hold nothing
    x0 = std::max(x0, cell_lo_[0]);
    x1 = std::min(x1, cell_lo_[0] + cell_count_[0] - 1);
    y0 = std::max(y0, cell_lo_[1]);
    y1 = std::min(y1, cell_lo_[1] + cell_count_[1] - 1);
  }
  for (std::int64_t cx = x0; cx <= x1; ++cx) {
    // Distance from p to the slab of cells cx along x (0 inside it).
    const double gap_x = std::max({0.0, static_cast<double>(cx) * c - p.x, p.x - static_cast<double>(cx + 1) * c});
    for (std::int64_t cy = y0; cy <= y1; ++cy) {
      const double gap_y = std::max({0.0, static_cast<double>(cy) * c - p.y, p.y - static_cast<double>(cy + 1) * c});
      const double left = reach2 - gap_x * gap_x - gap_y * gap_y;
      if (left <= 0) continue;
      const double half_height = std::sqrt(left);
      const atom_range range = row_atoms(cx, cy, cell_of(p.z - half_height, 2), cell_of(p.z + half_height, 2));
      if (range.begin < range.end) visit(range);
    }
  }
}

namespace {

/// The atoms within their cutoff of one point, gathered before their kernels are summed: only about a third of the
/// atoms in the visited cell rows are, and rows hold a few atoms each, so summing straight from the rows would
/// leave most vector lanes empty.
template <int W>
struct inside_atoms {
  static constexpr int capacity = 256;
  // Spare entries: the screening writes whole groups of four.
  std::array<std::uint32_t, capacity + (W > 4 ? W : 4)> index;
  int count = 0;
};

using index4 = std::uint32_t __attribute__((vector_size(16)));

/// For each 4-bit lane mask, the numbers of its set lanes in increasing order (then anything): storing
/// first + table[mask] and advancing by popcount(mask) appends the selected lanes in one store, where appending
/// lane by lane made every entry wait for the previous count (6% of a capsid's run time in that one line).
constexpr std::array<std::array<std::uint32_t, 4>, 16> make_compress_table() {
  std::array<std::array<std::uint32_t, 4>, 16> table{};
  for (unsigned mask = 0; mask < 16; ++mask) {
    int out = 0;
    for (unsigned lane = 0; lane < 4; ++lane) {
      if (mask & (1U << lane)) table[mask][out++] = lane;
    }
  }
  return table;
}
constexpr std::array<std::array<std::uint32_t, 4>, 16> compress_table = make_compress_table();

/// Bits 0..3 of the lanes group..group + 3 of `mask` (bit j set where lane group + j is set).
template <class M>
[[gnu::always_inline]] inline unsigned lane_bits_of_group(const M& mask, int group) {
  constexpr int lanes = static_cast<int>(sizeof(M) / sizeof(std::int64_t));
  unsigned bits = 0;
  for (int j = group; j < std::min(group + 4, lanes); ++j) bits |= static_cast<unsigned>(mask[j] & 1) << (j - group);
  return bits;
}
/// Bit j set where lane j of `mask` is set.
template <class M>
[[gnu::always_inline]] inline unsigned lane_bits(const M& mask) {
  return lane_bits_of_group(mask, 0);
}
// With GCC, one movmskpd: building the bits lane by lane took a sixth of a point evaluation (field_bench
// point_value_and_gradient, mache: 68 → 57 ms). GCC checks the instruction set where the kernel is inlined into
// dispatch()'s AVX2 and AVX-512 functions, the only ones with 4 lanes; Clang checks it here, so it builds the bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
template <>
[[gnu::always_inline]] inline unsigned lane_bits(const simd::pack<2>::i64& mask) {
  return static_cast<unsigned>(__builtin_ia32_movmskpd(reinterpret_cast<simd::pack<2>::f64>(mask)));
}
template <>
[[gnu::always_inline]] inline unsigned lane_bits(const simd::pack<4>::i64& mask) {
  return static_cast<unsigned>(__builtin_ia32_movmskpd256(reinterpret_cast<simd::pack<4>::f64>(mask)));
}
#endif

/// Appends to `inside` the atoms of [begin, end) within their cutoff of p, W at a time (branch-free).
template <int W>
[[gnu::always_inline]] inline void screen(const gaussian_field::atom_arrays& atoms, std::uint32_t begin,
                                          std::uint32_t end, const vec3& p, inside_atoms<W>& inside) {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  for (std::uint32_t k = begin; k < end; k += W) {
    F dx, dy, dz, cutoff2;
    simd::load(dx, atoms.x + k);
    simd::load(dy, atoms.y + k);
    simd::load(dz, atoms.z + k);
    simd::load(cutoff2, atoms.cutoff2 + k);
    dx = p.x - dx;
    dy = p.y - dy;
    dz = p.z - dz;
    M within = dx * dx + dy * dy + dz * dz < cutoff2;
    simd::clear_lanes_from(within, k, end);
    for (int group = 0; group < W; group += 4) {
      const unsigned mask = W <= 4 ? lane_bits(within) : lane_bits_of_group(within, group);
      index4 selected;
      __builtin_memcpy(&selected, compress_table[mask].data(), sizeof selected);
      selected += k + static_cast<std::uint32_t>(group);
      __builtin_memcpy(&inside.index[static_cast<std::size_t>(inside.count)], &selected, sizeof selected);
      inside.count += __builtin_popcount(mask);
    }
  }
}

/// Adds the kernels of the gathered atoms at p to `sums`, W at a time; lane j receives atoms j, j + W, … of the
/// list, so the order is fixed by the list.
template <int W, bool with_gradient, bool with_dominant>
[[gnu::always_inline]] inline void sum_kernels(const gaussian_field::atom_arrays& atoms,
                                               const inside_atoms<W>& inside, const vec3& p, double d,
                                               lane_sums<W>& sums) {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  for (int first = 0; first < inside.count; first += W) {
    F dx, dy, dz, inv_r2;
    M index;
    for (int j = 0; j < W; ++j) {
      const std::uint32_t k = inside.index[static_cast<std::size_t>(std::min(first + j, inside.count - 1))];
      dx[j] = atoms.x[k];
      dy[j] = atoms.y[k];
      dz[j] = atoms.z[k];
      inv_r2[j] = atoms.inv_r2[k];
      if constexpr (with_dominant) index[j] = atoms.original_index[k];
    }
    M valid = M{} - 1;
    simd::clear_lanes_from(valid, first, inside.count);
    dx = p.x - dx;
    dy = p.y - dy;
    dz = p.z - dz;
    const F r2 = dx * dx + dy * dy + dz * dz;
    F kernel = d * (r2 * inv_r2 - 1);
    simd::exp_in_place(kernel);
    simd::keep_lanes(kernel, valid);
    sums.value += kernel;
    if constexpr (with_gradient) {
      const F s = 2 * d * inv_r2 * kernel;  // ∂/∂x of exp(d(|x−c|²/r² − 1)) = 2d(x−c)/r² · kernel
      sums.gx += s * dx;
      sums.gy += s * dy;
      sums.gz += s * dz;
    }
    if constexpr (with_dominant) {
      const M better = valid & ((kernel > sums.best_kernel) | ((kernel == sums.best_kernel) & (index < sums.best_index)));
      sums.best_kernel = reinterpret_cast<F>((reinterpret_cast<M>(kernel) & better) |
                                             (reinterpret_cast<M>(sums.best_kernel) & ~better));
      sums.best_index = (index & better) | (sums.best_index & ~better);
    }
  }
}

/// The best (kernel, index) over the lanes; index −1 when no lane saw an atom within its cutoff.
template <int W>
std::int64_t best_lane_index(const lane_sums<W>& sums) {
  double best = -1;
  std::int64_t index = -1;
  for (int j = 0; j < W; ++j) {
    if (sums.best_index[j] < 0) continue;
    if (sums.best_kernel[j] > best || (sums.best_kernel[j] == best && sums.best_index[j] < index)) {
      best = sums.best_kernel[j];
      index = sums.best_index[j];
    }
  }
  return index;
}

/// Sums the kernels of the gathered atoms but the last (count mod W), which move to the front of the list: every atom
/// keeps lane (its position in the whole evaluation) mod W, as if the list never filled, so the sums do not depend on
/// how the atoms came in ranges (a cell row or a field_neighbourhood give the same bits).
template <int W, bool with_gradient, bool with_dominant>
[[gnu::always_inline]] inline void sum_full_groups(const gaussian_field::atom_arrays& atoms, inside_atoms<W>& inside,
                                                   const vec3& p, double d, lane_sums<W>& sums) {
  const int listed = inside.count, full = listed / W * W;
  inside.count = full;
  sum_kernels<W, with_gradient, with_dominant>(atoms, inside, p, d, sums);
  for (int n = full; n < listed; ++n) {
    inside.index[static_cast<std::size_t>(n - full)] = inside.index[static_cast<std::size_t>(n)];
  }
  inside.count = listed - full;
}

/// Screens atoms [begin, end) into `inside`, summing full groups first whenever a piece might not fit.
template <int W, bool with_gradient, bool with_dominant>
[[gnu::always_inline]] inline void add_atoms(const gaussian_field::atom_arrays& atoms, std::uint32_t begin,
                                             std::uint32_t end, const vec3& p, double d, inside_atoms<W>& inside,
                                             lane_sums<W>& sums) {
  while (begin < end) {
    // Pieces of at most half the list: after summing the full groups fewer than W atoms are left, so a piece fits.
    const std::uint32_t piece_end = std::min<std::uint32_t>(end, begin + inside_atoms<W>::capacity / 2);
    if (inside.count + static_cast<int>(piece_end - begin) > inside_atoms<W>::capacity) {
      sum_full_groups<W, with_gradient, with_dominant>(atoms, inside, p, d, sums);
    }
    screen(atoms, begin, piece_end, p, inside);
    begin = piece_end;
  }
}

/// The evaluation's result from its lane sums (the dominant atom's index −1 when no atom was within its cutoff).
template <int W, bool with_gradient, bool with_dominant>
[[gnu::always_inline]] inline gaussian_field::point_probe probe_of(const lane_sums<W>& sums,
                                                                   std::int64_t& dominant) {
  gaussian_field::point_probe out{simd::lane_sum(sums.value), {}, 0};
  if constexpr (with_gradient) {
    out.gradient = {simd::lane_sum(sums.gx), simd::lane_sum(sums.gy), simd::lane_sum(sums.gz)};
  }
  if constexpr (with_dominant) dominant = best_lane_index(sums);
  return out;
}

}  // namespace

template <int W, bool with_gradient, bool with_dominant>
[[gnu::always_inline]] inline gaussian_field::point_probe gaussian_field::evaluate_list(const atom_arrays& list,
                                                                                        std::uint32_t count,
                                                                                        const vec3& p) const {
  lane_sums<W> sums;
  inside_atoms<W> inside;
  add_atoms<W, with_gradient, with_dominant>(list, 0, count, p, d_, inside, sums);
  sum_kernels<W, with_gradient, with_dominant>(list, inside, p, d_, sums);
  std::int64_t dominant = -1;
  point_probe out = probe_of<W, with_gradient, with_dominant>(sums, dominant);
  if constexpr (with_dominant) out.dominant_atom = dominant >= 0 ? static_cast<std::uint32_t>(dominant) : nearest_atom(p);
  return out;
}

template <int W, bool with_gradient, bool with_dominant>
[[gnu::always_inline]] inline gaussian_field::point_probe gaussian_field::evaluate(const vec3& p) const {
  lane_sums<W> sums;
  inside_atoms<W> inside;
  const atom_arrays a = atoms();
  // The rows' ranges are all found before any is screened: each is a chain of dependent scalar steps (square root,
  // cell, table), and the processor overlaps independent chains (field_bench point_value_and_gradient, mache:
  // 57 → 49 ms).
  std::array<atom_range, 16> ranges;
  std::size_t range_count = 0;
  const auto screen_ranges = [&]() __attribute__((always_inline)) {
    for (std::size_t n = 0; n < range_count; ++n) {
      add_atoms<W, with_gradient, with_dominant>(a, ranges[n].begin, ranges[n].end, p, d_, inside, sums);
    }
    range_count = 0;
  };
  for_each_nearby_range(p, [&](atom_range r) __attribute__((always_inline)) {
    if (range_count == ranges.size()) screen_ranges();
    ranges[range_count++] = r;
  });
  screen_ranges();
  sum_kernels<W, with_gradient, with_dominant>(a, inside, p, d_, sums);
  std::int64_t dominant = -1;
  point_probe out = probe_of<W, with_gradient, with_dominant>(sums, dominant);
  if constexpr (with_dominant) out.dominant_atom = dominant >= 0 ? static_cast<std::uint32_t>(dominant) : nearest_atom(p);
  return out;
}

double gaussian_field::value_and_gradient_over(const atom_arrays& list, std::uint32_t count, const vec3& p,
                                               vec3& gradient) const {
  const point_probe out = simd::dispatch<point_lanes>([&](auto lanes) __attribute__((always_inline)) {
    return evaluate_list<decltype(lanes)::value, true, false>(list, count, p);
  });
  gradient = out.gradient;
  return out.value;
}

double gaussian_field::value(const vec3& p) const {
  return simd::dispatch<point_lanes>([&](auto lanes) __attribute__((always_inline)) {
    return evaluate<decltype(lanes)::value, false, false>(p).value;
  });
}

double gaussian_field::value_and_gradient(const vec3& p, vec3& gradient) const {
  const point_probe out = simd::dispatch<point_lanes>([&](auto lanes) __attribute__((always_inline)) {
    return evaluate<decltype(lanes)::value, true, false>(p);
  });
  gradient = out.gradient;
  return out.value;
}

std::uint32_t gaussian_field::dominant_atom(const vec3& p) const {
  return simd::dispatch<point_lanes>([&](auto lanes) __attribute__((always_inline)) {
    return evaluate<decltype(lanes)::value, false, true>(p).dominant_atom;
  });
}

gaussian_field::point_probe gaussian_field::probe(const vec3& p) const {
  return simd::dispatch<point_lanes>([&](auto lanes) __attribute__((always_inline)) {
    return evaluate<decltype(lanes)::value, true, true>(p);
  });
}

int simd::widest_lanes() {
#if defined(__x86_64__)
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq")) {
    return 8;
  }
  if (__builtin_cpu_supports("avx2")) return 4;
#endif
  return 2;
}

std::uint32_t gaussian_field::nearest_atom(const vec3& p) const {
  // Beyond every cutoff (cannot happen on the surface): the nearest centre, ties to the lower index.
  std::uint32_t best_index = std::numeric_limits<std::uint32_t>::max();
  double nearest = std::numeric_limits<double>::infinity();
  for (std::uint32_t k = 0; k < atom_count(); ++k) {
    const double r2 = squared_norm(p - vec3{x_[k], y_[k], z_[k]});
    if (r2 < nearest || (r2 == nearest && original_index_[k] < best_index)) {
      nearest = r2;
      best_index = original_index_[k];
    }
  }
  return best_index;
}

double gaussian_field::point_probe::surface_distance(double t0) const {
  const double gn = norm(gradient);
  return gn > 0 ? std::abs(value - t0) / gn : std::numeric_limits<double>::infinity();
}

double gaussian_field::surface_distance(const vec3& p) const {
  vec3 g;
  const double phi = value_and_gradient(p, g);
  const double gn = norm(g);
  return gn > 0 ? std::abs(phi - t0_) / gn : std::numeric_limits<double>::infinity();
}

bool gaussian_field::project_to_surface(vec3& p, double max_move) const {
  vec3 q = p;
  for (int iteration = 0; iteration < 40; ++iteration) {
    vec3 g;
    const double residual = value_and_gradient(q, g) - t0_;
    const double g2 = squared_norm(g);
    if (g2 == 0) return false;
    if (std::abs(residual) <= 1e-12 * t0_ || std::abs(residual) / std::sqrt(g2) < 1e-10) {
      p = q;
      return true;
    }
    vec3 step = g * (residual / g2);  // Newton along the gradient line
    const double step_length = norm(step);
    if (step_length > 0.5 * max_move) step *= 0.5 * max_move / step_length;  // damped far from S
    q -= step;
    if (distance(q, p) > max_move) return false;
  }
  return false;
}

namespace {

/// gap = max(lo − c, 0, c − hi) in every lane: how far c lies outside [lo, hi].
template <class F>
[[gnu::always_inline]] inline void gap_to_interval(const F& c, double lo, double hi, F& gap) {
  const F below = lo - c, above = c - hi, zero{};
  const F outside = below > above ? below : above;
  gap = outside > zero ? outside : zero;
}

/// Stores at out[count..] the atoms of [begin, end) whose cutoff sphere may reach `box` (box distance² < cutoff² with
/// the selection slack), W at a time, branch-free; `out` has room for W entries beyond the last atom. Returns the new
/// count.
template <int W>
[[gnu::always_inline]] inline std::size_t select_near_box(const gaussian_field::atom_arrays& atoms,
                                                          std::uint32_t begin, std::uint32_t end, const box3& box,
                                                          std::uint32_t* out, std::size_t count) {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  for (std::uint32_t k = begin; k < end; k += W) {
    F x, y, z, cutoff2, dx, dy, dz;
    simd::load(x, atoms.x + k);
    simd::load(y, atoms.y + k);
    simd::load(z, atoms.z + k);
    simd::load(cutoff2, atoms.cutoff2 + k);
    gap_to_interval(x, box.lo.x, box.hi.x, dx);
    gap_to_interval(y, box.lo.y, box.hi.y, dy);
    gap_to_interval(z, box.lo.z, box.hi.z, dz);
    M near = dx * dx + dy * dy + dz * dz < cutoff2 * (1 + selection_slack);
    simd::clear_lanes_from(near, k, end);
    for (int group = 0; group < W; group += 4) {
      const unsigned mask = W <= 4 ? lane_bits(near) : lane_bits_of_group(near, group);
      index4 selected;
      __builtin_memcpy(&selected, compress_table[mask].data(), sizeof selected);
      selected += k + static_cast<std::uint32_t>(group);
      __builtin_memcpy(out + count, &selected, sizeof selected);
      count += static_cast<std::size_t>(__builtin_popcount(mask));
    }
  }
  return count;
}

}  // namespace

void gaussian_field::atoms_near_box(const box3& box, std::vector<std::uint32_t>& out) const {
  out.clear();
  if (atom_count() == 0) return;
  const auto magnitude = [](const vec3& v) { return std::abs(v.x) + std::abs(v.y) + std::abs(v.z); };
  const double reach = selection_reach(max_cutoff_, std::max(magnitude(box.lo), magnitude(box.hi)));
  std::int64_t lo[3], hi[3];
  for (int axis = 0; axis < 3; ++axis) {
    lo[axis] = cell_of(box.lo[axis] - reach, axis);
    hi[axis] = cell_of(box.hi[axis] + reach, axis);
    if (dense_) {  // cells outside the table hold nothing
      lo[axis] = std::max(lo[axis], cell_lo_[axis]);
      hi[axis] = std::min(hi[axis], cell_lo_[axis] + cell_count_[axis] - 1);
    }
    if (lo[axis] > hi[axis]) return;
  }
  std::size_t count = 0;
  const atom_arrays all = atoms();
  const auto add_near = [&](std::uint32_t begin, std::uint32_t end) {
    if (out.size() < count + (end - begin) + simd::max_lanes) {
      out.resize(std::max(2 * out.size(), count + (end - begin) + simd::max_lanes));
    }
    count = simd::dispatch<point_lanes>([&](auto lanes) __attribute__((always_inline)) {
      return select_near_box<decltype(lanes)::value>(all, begin, end, box, out.data(), count);
    });
  };
  const double rows = static_cast<double>(hi[0] - lo[0] + 1) * static_cast<double>(hi[1] - lo[1] + 1);
  if (rows > static_cast<double>(atom_count())) {  // a box wide in cells (tiny radii): scanning is cheaper
    add_near(0, static_cast<std::uint32_t>(atom_count()));
    out.resize(count);
    return;
  }
  // Rows whose cells the box grown by the reach cannot touch are skipped, and each row's z span is trimmed to it.
  const double c = cell_size_[0];
  const auto gap = [c](std::int64_t cell, double lo_edge, double hi_edge) {
    return std::max({0.0, static_cast<double>(cell) * c - hi_edge, lo_edge - static_cast<double>(cell + 1) * c});
  };
  for (std::int64_t cx = lo[0]; cx <= hi[0]; ++cx) {
    const double gap_x = gap(cx, box.lo.x, box.hi.x);
    for (std::int64_t cy = lo[1]; cy <= hi[1]; ++cy) {
      const double gap_y = gap(cy, box.lo.y, box.hi.y);
      const double left = reach * reach - gap_x * gap_x - gap_y * gap_y;
      if (left <= 0) continue;
      const double half_height = std::sqrt(left);
      const atom_range range =
          row_atoms(cx, cy, cell_of(box.lo.z - half_height, 2), cell_of(box.hi.z + half_height, 2));
      if (range.begin < range.end) add_near(range.begin, range.end);
    }
  }
  out.resize(count);
}

field_neighbourhood::field_neighbourhood(const gaussian_field& field, const vec3& reach)
    : field_(field), reach_(reach) {}

bool field_neighbourhood::covers(const vec3& p) const {
  return gathered_ && p.x >= box_.lo.x && p.x <= box_.hi.x && p.y >= box_.lo.y && p.y <= box_.hi.y &&
         p.z >= box_.lo.z && p.z <= box_.hi.z;
}

void field_neighbourhood::gather(const vec3& centre) {
  box_ = {centre - reach_, centre + reach_};
  field_.atoms_near_box(box_, indices_);
  const std::size_t count = indices_.size(), padded = count + simd::max_lanes - 1;
  for (auto* column : {&x_, &y_, &z_, &inv_r2_, &cutoff2_}) {
    if (column->size() < padded) column->resize(padded);
    std::fill(column->begin() + static_cast<std::ptrdiff_t>(count), column->begin() + static_cast<std::ptrdiff_t>(padded),
              0.0);  // padding: cutoff2 = 0, never contributes
  }
  if (original_index_.size() < padded) original_index_.resize(padded);
  const gaussian_field::atom_arrays all = field_.atoms();
  for (std::size_t n = 0; n < count; ++n) {
    const std::uint32_t k = indices_[n];
    x_[n] = all.x[k];
    y_[n] = all.y[k];
    z_[n] = all.z[k];
    inv_r2_[n] = all.inv_r2[k];
    cutoff2_[n] = all.cutoff2[k];
    original_index_[n] = all.original_index[k];
  }
  gathered_ = true;
  ++gathers_;
}

double field_neighbourhood::value_and_gradient(const vec3& p, vec3& gradient) {
  // Only points in the box may use its atoms: a point outside (or NaN) gathers a new box, or, not finite, is the
  // field's to evaluate.
  if (!covers(p)) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) return field_.value_and_gradient(p, gradient);
    gather(p);
  }
  const gaussian_field::atom_arrays list{x_.data(),       y_.data(),       z_.data(),
                                         inv_r2_.data(),  cutoff2_.data(), original_index_.data()};
  return field_.value_and_gradient_over(list, static_cast<std::uint32_t>(indices_.size()), p, gradient);
}

}  // namespace tracemesh
