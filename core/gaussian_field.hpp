#pragma once
/// @file gaussian_field.hpp
/// The Gaussian field φ(x) = Σᵢ exp(d·(|x−cᵢ|²/rᵢ² − 1)) (paper eq. 2) and its gradient, summed over nearby atoms
/// only. Each atom is cut off at |x−cᵢ| = U·rᵢ, with U chosen per job so that the neglected tail is at most
/// 1e-6·t0 anywhere, assuming at most `max_atom_number_density` atom centres per Å³ (see cutoff_factor()).
/// Atoms of radius 0 do not contribute. Evaluation order is fixed: results are bitwise reproducible.
///
/// Every exponential of the mesher's front end (field, culling, sampling, edge roots) is kernel_exp() or its
/// four-lane form simd::exp_in_place(): one formula, so a quantity computed twice gives the same bits.

#include <cstdint>
#include <span>
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

/// Four doubles worked on together: one AVX2 register, two SSE2 registers. GCC/Clang vector extensions, so the
/// arithmetic reads like scalar code and comparisons give lane masks (all bits set where true).
using f64x4 = double __attribute__((vector_size(32)));
using i64x4 = std::int64_t __attribute__((vector_size(32)));
inline constexpr int lanes = 4;

/// e^x in every lane, in place. Cody–Waite reduction x = n·ln2 + r with |r| ≤ ln2/2, the degree-13 Taylor
/// polynomial of e^r (truncation < 2⁻⁵⁸) by Estrin's scheme (a short dependency chain), and 2ⁿ built in the exponent
/// bits. Within 1 ulp of e^x for −708 ≤ x ≤ 709; exactly 0 for x < −708 and for NaN. No branches, no tables.
/// Taken by reference: passing 32-byte vectors by value would depend on whether the caller was compiled for AVX.
inline void exp_in_place(f64x4& x) {
  constexpr double log2e = 1.4426950408889634074;
  constexpr double ln2_hi = 6.93147180369123816490e-01;  // 32 significant bits: n·ln2_hi is exact
  constexpr double ln2_lo = 1.90821492927058770002e-10;
  constexpr double round_shift = 0x1.8p52;  // adding it rounds to an integer held in the low mantissa bits
  const i64x4 keep = x >= -708.0;
  const f64x4 clamped = reinterpret_cast<f64x4>(reinterpret_cast<i64x4>(x) & keep);  // 0 where dropped
  const f64x4 shifted = clamped * log2e + round_shift;
  const f64x4 n = shifted - round_shift;
  const f64x4 r = (clamped - n * ln2_hi) - n * ln2_lo;
  // Σ r^k / k! for k = 0..13, as pairs (1/k! + r/(k+1)!), combined with r², r⁴, r⁸.
  const f64x4 r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const f64x4 p01 = 1.0 + r, p23 = 1.0 / 2 + r * (1.0 / 6), p45 = 1.0 / 24 + r * (1.0 / 120);
  const f64x4 p67 = 1.0 / 720 + r * (1.0 / 5040), p89 = 1.0 / 40320 + r * (1.0 / 362880);
  const f64x4 p1011 = 1.0 / 3628800 + r * (1.0 / 39916800), p1213 = 1.0 / 479001600 + r * (1.0 / 6227020800);
  const f64x4 p03 = p01 + r2 * p23, p47 = p45 + r2 * p67, p811 = p89 + r2 * p1011;
  const f64x4 p07 = p03 + r4 * p47, p813 = p811 + r4 * p1213;
  const f64x4 p = p07 + r8 * p813;
  // Low bits of `shifted` hold n; (n + 1023) << 52 is the bit pattern of 2ⁿ.
  const i64x4 two_to_n = ((reinterpret_cast<i64x4>(shifted) + 1023) << 52) & keep;
  x = p * reinterpret_cast<f64x4>(two_to_n);
}

// Small helpers, all by reference for the same reason.
inline void load(f64x4& v, const double* p) { __builtin_memcpy(&v, p, sizeof v); }
inline void store(double* p, const f64x4& v) { __builtin_memcpy(p, &v, sizeof v); }
/// Zeroes the lanes where `mask` is clear.
inline void keep_lanes(f64x4& v, const i64x4& mask) {
  v = reinterpret_cast<f64x4>(reinterpret_cast<i64x4>(v) & mask);
}
inline bool any_lane(const i64x4& mask) { return (mask[0] | mask[1] | mask[2] | mask[3]) != 0; }
/// Sum of the lanes in a fixed order.
inline double lane_sum(const f64x4& v) { return (v[0] + v[1]) + (v[2] + v[3]); }
/// Clears lanes j with first + j ≥ end: keeps the valid part of a four-lane load at `first`.
inline void clear_lanes_from(i64x4& mask, std::int64_t first, std::int64_t end) {
  const i64x4 lane{0, 1, 2, 3};
  mask &= lane < end - first;
}

}  // namespace simd

/// e^x as every stage of the mesher computes it (simd::exp_in_place on one lane; same bits).
inline double kernel_exp(double x) {
  simd::f64x4 v = {x, x, x, x};
  simd::exp_in_place(v);
  return v[0];
}

/// Axis-aligned box, Å.
struct box3 {
  vec3 lo, hi;
};

class gaussian_field {
 public:
  /// Builds the neighbour structure: atoms sorted into cubic cells of a third of the largest cutoff, indexed by a
  /// dense cell table when the atoms' bounding box holds few enough cells (memory O(atoms)), by hashed cell rows
  /// otherwise (two atoms 10⁵ Å apart cost nothing).
  /// Preconditions: d < 0, t0 > 0, radii ≥ 0 and finite coordinates (validated by the reader and validate()).
  gaussian_field(const molecule& mol, double d, double t0);

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
  /// simd::lanes − 1 padding entries (cutoff2 = 0, so they never contribute), so a four-lane load starting at any
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

  std::int64_t cell_of(double coordinate) const;
  static std::uint64_t row_key(std::int64_t cx, std::int64_t cy);
  /// Atoms of the cells cz ∈ [z0, z1] of row (cx, cy).
  atom_range row_atoms(std::int64_t cx, std::int64_t cy, std::int64_t z0, std::int64_t z1) const;
  /// Calls visit(range) for the cell rows that may hold atoms within max_cutoff of p: rows outside the sphere are
  /// skipped and each row's z span is trimmed to the sphere. Ranges come in ascending internal order.
  template <class Visitor>
  void for_each_nearby_range(const vec3& p, Visitor&& visit) const;
  /// Nearest centre by brute force (for points beyond every cutoff).
  std::uint32_t nearest_atom(const vec3& p) const;

  double d_, t0_;
  double cutoff_error_bound_ = 0;
  double max_radius_ = 0;
  double max_cutoff_ = 0;
  double cell_size_ = 1;
  double inverse_cell_size_ = 1;  ///< cell_of multiplies: cheaper than dividing, and atoms and queries agree
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

}  // namespace tracemesh
