#pragma once
/// @file gaussian_field.hpp
/// The Gaussian field φ(x) = Σᵢ exp(d·(|x−cᵢ|²/rᵢ² − 1)) (paper eq. 2) and its gradient, summed over nearby atoms
/// only. Each atom is cut off at |x−cᵢ| = U·rᵢ, with U chosen per job so that the neglected tail is at most
/// 1e-6·t0 anywhere, assuming at most `max_atom_number_density` atom centres per Å³ (see cutoff_factor()).
/// Atoms of radius 0 do not contribute. Evaluation order is fixed: results are bitwise reproducible.
///
/// Every exponential of the mesher's front end (field, culling, sampling, edge roots) is simd::exp_in_place() or its
/// one-lane form kernel_exp(): one formula, so a quantity computed twice gives the same bits.

#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include "core/molecule.hpp"
#include "core/vec3.hpp"

namespace tracemesh {

/// Atom centres per Å³ assumed by the cutoff error bound: 2.5× the density of a protein with hydrogens
/// (≈ 0.1 Å⁻³); even the capsid's clashing pairs stay below it.
inline constexpr double max_atom_number_density = 0.25;
/// Target bound on the neglected tail of φ, relative to t0.
inline constexpr double field_cutoff_tolerance = 1e-6;

/// U such that ρ·4π·r³·e^(−d)·∫_U^∞ u² e^(d u²) du ≤ tolerance·t0 for the largest radius r (the tail of one
/// kernel integrated over a uniform atom density ρ). Cutoff radius of atom i is U·rᵢ.
double cutoff_factor(double d, double t0, double max_radius, double tolerance = field_cutoff_tolerance);

namespace simd {

/// W doubles, or W 64-bit integers (masks, bit patterns), worked on together: GCC/Clang vector extensions, so the
/// arithmetic reads like scalar code and comparisons give lane masks (all bits set where true). Kernels are templates
/// on W, compiled for AVX-512 (W = 8), AVX2 (W = 4) and SSE2 (W = 2) and chosen at run time (dispatch()).
/// Vectors are always passed by reference: by value, their calling convention would depend on the instruction set.
template <int W>
struct pack {
  typedef double f64 __attribute__((vector_size(8 * W)));
  typedef std::int64_t i64 __attribute__((vector_size(8 * W)));
};
/// The mask type of a double vector F, and its lane count.
template <class F>
using mask_of = decltype(F{} < F{});
template <class F>
inline constexpr int lanes_of = static_cast<int>(sizeof(F) / sizeof(double));
/// Widest vector the front end uses: arrays read W at a time are padded to a multiple of it.
inline constexpr int max_lanes = 8;

/// e^x in every lane, in place. Cody–Waite reduction x = n·ln2 + r with |r| ≤ ln2/2, the degree-13 Taylor
/// polynomial of e^r (truncation < 2⁻⁵⁸) by Estrin's scheme (a short dependency chain), and 2ⁿ built in the exponent
/// bits. Within 2 ulp of e^x for −708 ≤ x ≤ 709; exactly 0 for x < −708 and for NaN. No branches, no tables.
template <class F>
[[gnu::always_inline]] inline void exp_in_place(F& x) {
  using M = mask_of<F>;
  constexpr double log2e = 1.4426950408889634074;
  constexpr double ln2_hi = 6.93147180369123816490e-01;  // 32 significant bits: n·ln2_hi is exact
  constexpr double ln2_lo = 1.90821492927058770002e-10;
  constexpr double round_shift = 0x1.8p52;  // adding it rounds to an integer held in the low mantissa bits
  const M keep = x >= -708.0;
  const F clamped = reinterpret_cast<F>(reinterpret_cast<M>(x) & keep);  // 0 where dropped
  const F shifted = clamped * log2e + round_shift;
  const F n = shifted - round_shift;
  const F r = (clamped - n * ln2_hi) - n * ln2_lo;
  // Σ r^k / k! for k = 0..13, as pairs (1/k! + r/(k+1)!), combined with r², r⁴, r⁸.
  const F r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const F p01 = 1.0 + r, p23 = 1.0 / 2 + r * (1.0 / 6), p45 = 1.0 / 24 + r * (1.0 / 120);
  const F p67 = 1.0 / 720 + r * (1.0 / 5040), p89 = 1.0 / 40320 + r * (1.0 / 362880);
  const F p1011 = 1.0 / 3628800 + r * (1.0 / 39916800), p1213 = 1.0 / 479001600 + r * (1.0 / 6227020800);
  const F p03 = p01 + r2 * p23, p47 = p45 + r2 * p67, p811 = p89 + r2 * p1011;
  const F p07 = p03 + r4 * p47, p813 = p811 + r4 * p1213;
  const F p = p07 + r8 * p813;
  // Low bits of `shifted` hold n; (n + 1023) << 52 is the bit pattern of 2ⁿ.
  const M two_to_n = ((reinterpret_cast<M>(shifted) + 1023) << 52) & keep;
  x = p * reinterpret_cast<F>(two_to_n);
}

template <class F>
[[gnu::always_inline]] inline void load(F& v, const double* p) {
  __builtin_memcpy(&v, p, sizeof v);
}
template <class F>
[[gnu::always_inline]] inline void store(double* p, const F& v) {
  __builtin_memcpy(p, &v, sizeof v);
}
/// Zeroes the lanes where `mask` is clear. (Bitwise, so a product is never fused with a later sum.)
template <class F>
[[gnu::always_inline]] inline void keep_lanes(F& v, const mask_of<F>& mask) {
  v = reinterpret_cast<F>(reinterpret_cast<mask_of<F>>(v) & mask);
}
/// The scalar form of keep_lanes.
[[gnu::always_inline]] inline void keep_if(double& v, bool keep) {
  std::uint64_t bits;
  __builtin_memcpy(&bits, &v, sizeof bits);
  bits &= std::uint64_t{0} - static_cast<std::uint64_t>(keep);
  __builtin_memcpy(&v, &bits, sizeof v);
}
template <class M>
[[gnu::always_inline]] inline bool any_lane(const M& mask) {
  std::int64_t any = 0;
  for (std::size_t j = 0; j < sizeof(M) / sizeof(std::int64_t); ++j) any |= mask[j];
  return any != 0;
}
/// Sum of the lanes, pairwise in a fixed order.
template <class F>
[[gnu::always_inline]] inline double lane_sum(const F& lanes) {
  F v = lanes;
  for (int width = lanes_of<F>; width > 1; width /= 2) {
    for (int j = 0; j < width / 2; ++j) v[j] = v[2 * j] + v[2 * j + 1];
  }
  return v[0];
}
/// Clears lanes j with first + j ≥ end: keeps the valid part of a load at `first`.
template <class M>
[[gnu::always_inline]] inline void clear_lanes_from(M& mask, std::int64_t first, std::int64_t end) {
  M lane;
  for (std::size_t j = 0; j < sizeof(M) / sizeof(std::int64_t); ++j) lane[j] = static_cast<std::int64_t>(j);
  mask &= lane < end - first;
}

/// 8 with AVX-512 (F, VL and DQ), 4 with AVX2, otherwise 2.
int widest_lanes();

}  // namespace simd

// The vector instruction sets of dispatch(). GCC may fuse a·b + c into one rounding where FMA exists (AVX-512);
// it is switched off so that every width gives the same roundings (Clang fuses only within one expression).
// AVX-512VL lets the 4-lane kernels use all 32 vector registers (AVX-512F alone gives 256-bit code only 16, and the
// point evaluation spilled its sums and constants to the stack); DQ gives its masks one-instruction conversions.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define TRACEMESH_TARGET_AVX512 __attribute__((target("avx512f,avx512vl,avx512dq"), optimize("fp-contract=off")))
#define TRACEMESH_TARGET_AVX2 __attribute__((target("avx2")))
#elif defined(__x86_64__)
#define TRACEMESH_TARGET_AVX512 __attribute__((target("avx512f,avx512vl,avx512dq")))
#define TRACEMESH_TARGET_AVX2 __attribute__((target("avx2")))
#endif

namespace simd {
namespace detail {
#if defined(TRACEMESH_TARGET_AVX512)
template <int W, class Body>
TRACEMESH_TARGET_AVX512 auto run_avx512(Body& body) {
  return body(std::integral_constant<int, W>{});
}
template <int W, class Body>
TRACEMESH_TARGET_AVX2 auto run_avx2(Body& body) {
  return body(std::integral_constant<int, W>{});
}
#endif
}  // namespace detail

/// Returns body(std::integral_constant<int, W>{}) run inside a function compiled for the widest vector unit of this
/// CPU, with W its lane count capped at MaxLanes (kernels that work on short runs of atoms are faster with 4 lanes
/// even where 8 are available). `body` must be always_inline (so that it is compiled for that unit) and must not
/// pass vectors across its own boundary. Results are the same for every W up to the grouping of lane sums.
template <int MaxLanes = max_lanes, class Body>
auto dispatch(Body&& body) {
#if defined(TRACEMESH_TARGET_AVX512)
  switch (widest_lanes()) {
    case 8:
      return detail::run_avx512<(MaxLanes < 8 ? MaxLanes : 8)>(body);
    case 4:
      return detail::run_avx2<(MaxLanes < 4 ? MaxLanes : 4)>(body);
    default:
      break;
  }
#endif
  return body(std::integral_constant<int, 2>{});
}

}  // namespace simd

/// e^x as every stage of the mesher computes it (simd::exp_in_place on one lane; same bits).
inline double kernel_exp(double x) {
  simd::pack<2>::f64 v = {x, x};
  simd::exp_in_place(v);
  return v[0];
}

class gaussian_field {
 public:
  /// Builds the neighbour structure: atoms sorted into cells (rows as wide as the largest cutoff, cut in z every
  /// eighth of it), indexed by a dense cell table when the atoms' bounding box holds few enough cells (memory
  /// O(atoms)), by hashed cell rows otherwise (two atoms 10⁵ Å apart cost nothing).
  /// Preconditions: d < 0, t0 > 0, radii ≥ 0 and finite coordinates (validated by the reader and validate()).
  /// `tolerance`: the bound on the neglected tail relative to t0 (see cutoff_factor). The mesh's own field keeps the
  /// default; a looser one gives a cheaper approximation (the trace path walks its contours on one).
  gaussian_field(const molecule& mol, double d, double t0, double tolerance = field_cutoff_tolerance);

  double d() const { return d_; }
  double t0() const { return t0_; }
  /// Bound on |φ_cutoff(x) − φ(x)| for any x (absolute, same units as φ).
  double cutoff_error_bound() const { return cutoff_error_bound_; }
  /// Bounding box of the contributing atom centres.
  const box3& atom_bounds() const { return atom_bounds_; }
  double max_radius() const { return max_radius_; }
  /// Largest per-atom cutoff radius, Å.
  double max_cutoff() const { return max_cutoff_; }
  std::size_t atom_count() const { return original_index_.size(); }

  /// φ(p).
  double value(const vec3& p) const;
  /// φ(p); writes ∇φ(p) to `gradient`.
  double value_and_gradient(const vec3& p, vec3& gradient) const;
  /// Index into the molecule's atoms of the atom with the largest kernel value at p (ties: the lower index).
  std::uint32_t dominant_atom(const vec3& p) const;

  /// Everything the mesh needs at a vertex, from one pass over the nearby atoms.
  struct point_probe {
    double value;               ///< φ(p)
    vec3 gradient;              ///< ∇φ(p)
    std::uint32_t dominant_atom;  ///< as dominant_atom(p)
    /// |φ − t0| / |∇φ|, Å
    double surface_distance(double t0) const;
  };
  point_probe probe(const vec3& p) const;
  /// |φ(p) − t0| / |∇φ(p)|: first-order distance from p to the surface, Å (infinity where ∇φ = 0).
  double surface_distance(const vec3& p) const;
  /// Moves p onto {φ = t0} by Newton steps along ∇φ (paper Algorithm 1, step 3). Returns false, leaving p
  /// unchanged, when it does not converge to 1e-9·t0 or would move more than max_move Å.
  bool project_to_surface(vec3& p, double max_move) const;

  /// Contributing atoms whose cutoff sphere may reach `box`, in ascending internal order (a few atoms that only
  /// graze it within rounding may be included). Used by culling and sampling.
  void atoms_near_box(const box3& box, std::vector<std::uint32_t>& out) const;

  /// One atom in the field's internal order (index k as returned by atoms_near_box).
  struct atom_data {
    double x, y, z;
    double inv_r2;      ///< 1 / rᵢ²
    double cutoff2;     ///< (U·rᵢ)²
    std::uint32_t original_index;  ///< index into molecule::atoms
  };
  atom_data atom_at(std::uint32_t k) const {
    return {x_[k], y_[k], z_[k], inv_r2_[k], cutoff2_[k], original_index_[k]};
  }
  /// The same data as structure of arrays, for vectorised loops. Each array holds atom_count() entries followed by
  /// simd::max_lanes − 1 padding entries (cutoff2 = 0, so they never contribute), so a vector load starting at any
  /// atom stays in bounds.
  struct atom_arrays {
    const double* x;
    const double* y;
    const double* z;
    const double* inv_r2;
    const double* cutoff2;
    const std::uint32_t* original_index;
  };
  atom_arrays atoms() const {
    return {x_.data(), y_.data(), z_.data(), inv_r2_.data(), cutoff2_.data(), original_index_.data()};
  }

 private:
  /// Atoms [begin, end) in internal order.
  struct atom_range {
    std::uint32_t begin = 0, end = 0;
  };
  /// Row (cx, cy) of cells in the sparse index.
  struct sparse_row {
    std::uint64_t key = empty_row;
    atom_range atoms;
  };
  static constexpr std::uint64_t empty_row = ~std::uint64_t{0};

  void sort_atoms(const molecule& mol, const std::vector<std::uint32_t>& contributing, double u);
  void build_dense_index(std::vector<std::int64_t>& cells, std::vector<std::uint32_t>& order);
  void build_sparse_index(std::vector<std::int64_t>& cells, std::vector<std::uint32_t>& order);
  void store_atoms(const molecule& mol, const std::vector<std::uint32_t>& contributing,
                   const std::vector<std::uint32_t>& order, double u);

  std::int64_t cell_of(double coordinate, int axis) const;
  static std::uint64_t row_key(std::int64_t cx, std::int64_t cy);
  /// Atoms of the cells cz ∈ [z0, z1] of row (cx, cy).
  atom_range row_atoms(std::int64_t cx, std::int64_t cy, std::int64_t z0, std::int64_t z1) const;
  /// Calls visit(range) for the cell rows that may hold atoms within max_cutoff of p: rows outside the sphere are
  /// skipped and each row's z span is trimmed to the sphere. Ranges come in ascending internal order.
  template <class Visitor>
  void for_each_nearby_range(const vec3& p, Visitor&& visit) const;
  /// Nearest centre by brute force (for points beyond every cutoff).
  std::uint32_t nearest_atom(const vec3& p) const;
  /// One pass over the atoms near p, W at a time: φ, and ∇φ and the dominant atom when asked for.
  template <int W, bool with_gradient, bool with_dominant>
  point_probe evaluate(const vec3& p) const;
  /// The same over the first `count` atoms of `list` (padded as atom_arrays), which hold every atom within its
  /// cutoff of p, in internal order: the same bits as evaluate().
  template <int W, bool with_gradient, bool with_dominant>
  point_probe evaluate_list(const atom_arrays& list, std::uint32_t count, const vec3& p) const;
  /// value_and_gradient() over such a list.
  double value_and_gradient_over(const atom_arrays& list, std::uint32_t count, const vec3& p, vec3& gradient) const;
  friend class field_neighbourhood;

  double d_, t0_;
  double cutoff_error_bound_ = 0;
  double max_radius_ = 0;
  double max_cutoff_ = 0;
  double cell_size_[3] = {1, 1, 1};          ///< per axis, Å (x and y equal)
  double inverse_cell_size_[3] = {1, 1, 1};  ///< cell_of multiplies: cheaper than dividing, and atoms and queries agree
  box3 atom_bounds_{};

  // Atoms sorted by (cell x, cell y, cell z, original index), structure of arrays, padded (see atom_arrays).
  std::vector<double> x_, y_, z_, inv_r2_, cutoff2_;
  std::vector<std::uint32_t> original_index_;

  // Cell index. Dense: cell_start_[(cx·ny + cy)·nz + cz] for cells relative to cell_lo_. Sparse: hashed rows, and
  // the z cell of every atom for a binary search inside its row.
  bool dense_ = true;
  std::int64_t cell_lo_[3] = {0, 0, 0};
  std::int64_t cell_count_[3] = {0, 0, 0};
  std::vector<std::uint32_t> cell_start_;
  std::vector<sparse_row> rows_;
  std::vector<std::int32_t> cell_z_;
};

/// The atoms of a field that may reach any point of a box, gathered once so that evaluations at points that stay in
/// it (the steps of a traced contour) skip the field's cell index and screen fewer atoms. Results are the field's,
/// bit for bit: the box holds every atom within its cutoff of any point in it, in the field's order, and the sums do
/// not depend on how the atoms are grouped. A point outside the box gathers a new box around itself.
/// Not thread-safe (one per thread); holds a reference to the field, which must outlive it.
class field_neighbourhood {
 public:
  /// `reach`: the box's half size along each axis, Å (0 along an axis the points never leave, such as the normal of
  /// the plane a contour is traced in).
  field_neighbourhood(const gaussian_field& field, const vec3& reach);

  const gaussian_field& field() const { return field_; }
  /// As field().value_and_gradient(p, gradient).
  double value_and_gradient(const vec3& p, vec3& gradient);
  /// True when p lies in the current box.
  bool covers(const vec3& p) const;
  /// Boxes gathered so far.
  std::size_t gathers() const { return gathers_; }
  /// Atoms in the current box.
  std::size_t atom_count() const { return indices_.size(); }

 private:
  void gather(const vec3& centre);

  const gaussian_field& field_;
  vec3 reach_;
  box3 box_{};
  bool gathered_ = false;
  std::size_t gathers_ = 0;
  std::vector<std::uint32_t> indices_;
  std::vector<double> x_, y_, z_, inv_r2_, cutoff2_;  ///< padded as gaussian_field::atom_arrays
  std::vector<std::uint32_t> original_index_;
};

}  // namespace tracemesh
