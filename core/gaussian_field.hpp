#pragma once
/// @file gaussian_field.hpp
/// The Gaussian field φ(x) = Σᵢ exp(d·(|x−cᵢ|²/rᵢ² − 1)) (paper eq. 2) and its gradient, summed over nearby atoms
/// only. Each atom is cut off at |x−cᵢ| = U·rᵢ, with U chosen per job so that the neglected tail is at most
/// 1e-6·t0 anywhere, assuming at most `max_atom_number_density` atom centres per Å³ (see cutoff_factor()).
/// Atoms of radius 0 do not contribute. Evaluation order is fixed: results are bitwise reproducible.

#include <cstdint>
#include <unordered_map>
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

/// Axis-aligned box, Å.
struct box3 {
  vec3 lo, hi;
};

class gaussian_field {
 public:
  /// Builds the neighbour structure (hashed cell rows; memory O(atoms) whatever the extent).
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
  std::size_t atom_count() const { return data_.size(); }

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

  /// Contributing atoms whose cutoff sphere may reach `box`, in ascending atom order. Used by culling and sampling.
  void atoms_near_box(const box3& box, std::vector<std::uint32_t>& out) const;

  /// Per-atom data in the field's internal order (index k = position in atoms_near_box output's space).
  struct atom_data {
    double x, y, z;
    double inv_r2;      ///< 1 / rᵢ²
    double cutoff2;     ///< (U·rᵢ)²
    std::uint32_t original_index;  ///< index into molecule::atoms
  };
  const atom_data& atom_at(std::uint32_t k) const { return data_[k]; }

 private:
  struct row_span {
    std::uint32_t begin, end;  ///< range of atoms (internal order) in this (cx, cy) row, sorted by cz
  };
  template <class Visitor>
  void visit_near(const vec3& p, Visitor&& visit) const;
  std::int64_t cell_of(double coordinate) const;
  static std::uint64_t row_key(std::int64_t cx, std::int64_t cy);

  double d_, t0_;
  double cutoff_error_bound_ = 0;
  double max_radius_ = 0;
  double max_cutoff_ = 0;
  double cell_size_ = 1;
  box3 atom_bounds_{};
  std::vector<atom_data> data_;          ///< sorted by (cx, cy, cz, original index)
  std::vector<std::int32_t> cell_z_;      ///< cz of each atom in data_
  std::unordered_map<std::uint64_t, row_span> rows_;
};

}  // namespace tracemesh
