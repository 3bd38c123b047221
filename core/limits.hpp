#pragma once
/// @file limits.hpp
/// Every limit of the mesher, named in one place with its safe default. The CLI and the server log them and let
/// users configure them; core functions take them as arguments and return errc::limit_exceeded when crossed.

#include <cstddef>
#include <cstdint>

namespace tracemesh {

struct mesh_limits {
  /// Atoms accepted from one input (the 1,082,160-atom dengue capsid fits with room to spare).
  std::size_t max_atoms = 2'000'000;
  /// |x|, |y|, |z| of any atom centre, Å. Larger values are almost surely unit or format errors.
  double max_abs_coordinate = 1e6;
  /// Atom radius, Å. Real force fields stay under 3 Å; larger values are format errors.
  double max_radius = 10.0;
  /// Bytes of one PQR line; a longer line is an error, not a quadratic scan.
  std::size_t max_line_bytes = 4096;
  /// Sampled lattice points: bounds memory and time whatever the density and extent.
  std::uint64_t max_lattice_points = 2'000'000'000ULL;
  /// Lattice index range per axis (the lattice key packs 20 bits per axis).
  std::int64_t max_lattice_extent = (1 << 20) - 2;
  /// Triangles in one output mesh.
  std::size_t max_triangles = 60'000'000;
};

/// Documented ranges of the per-job parameters.
struct parameter_ranges {
  static constexpr double min_density = 0.05;  ///< vertices per Å²
  static constexpr double max_density = 20.0;
  static constexpr double min_d = -20.0;       ///< decay rate d (< 0)
  static constexpr double max_d = -0.05;
  static constexpr double min_t0 = 1e-3;       ///< isovalue t0 (> 0)
  static constexpr double max_t0 = 100.0;
  /// Smallest resolvable atom: an atom's own surface sphere (radius r·√(1 + ln t0 / d), the surface of the atom
  /// alone) must be at least this many mesh edge lengths (√(2/(√3·density)) Å) in radius, unless its centre lies
  /// inside the surface of the resolvable atoms (buried: it cannot make a feature of its own). Smaller atoms make
  /// features the sampling cannot resolve (an atom of radius ≤ 0.006 Å underflows φ at the mesh's vertices and failed
  /// its certificate), so they are refused with errc::unresolvable_input naming the atom (HTTP 422). 0.3: real
  /// molecules pass at every density (AMBER/PARSE hydrogens are buried in their heavy atom), and 3,000 random
  /// molecules of 1–6 atoms (radii 1e-3–10 Å, every d, t0 and density 0.05–2, both methods) were all certified or
  /// refused as the user's error (tests/core/atom_resolution_test.cpp, TRACEMESH_PROPERTY_CASES=3000).
  static constexpr double min_atom_surface_radius_per_edge = 0.3;
  // The trace path's knobs (trace_parameters.hpp).
  static constexpr int min_legendre_degree = 2;
  static constexpr int max_legendre_degree = 30;
  static constexpr double min_trace_step_fraction = 0.05;  ///< h₁ / h̃
  static constexpr double max_trace_step_fraction = 2.0;
  static constexpr double min_trace_cos_bound = 0.5;       ///< δ: the normal may turn by at most 60°…
  static constexpr double max_trace_cos_bound = 0.9999;    ///< …and at least 0.8° per step
  static constexpr double min_extreme_tolerance = 1e-4;    ///< ε, relative to |∇φ|
  static constexpr double max_extreme_tolerance = 0.2;
};

}  // namespace tracemesh
