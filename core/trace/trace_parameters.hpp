#pragma once
/// @file trace_parameters.hpp
/// The knobs of the trace path (TMSmesh stage two: paper eq. 6, Algorithms 1 and 2) and what it counts while it
/// runs. Both appear in the job report, so a mesh can be reproduced from its report alone.

#include <array>
#include <cstddef>

namespace tracemesh {

struct trace_parameters {
  /// Degree M of the Legendre approximation of φ along each line span (paper eq. 6: M = 10).
  int legendre_degree = 10;
  /// Step h₁ of Algorithm 1 as a fraction of the line spacing h̃ (the first try of every step; steps grow back
  /// to it after a halving). 0.5: with h̃ = 1 Å, a 0.5 Å step, within the ~1 Å the prototype found still valid
  /// with a 20° turn limit (method.md §7.4).
  double step_fraction = 0.5;
  /// δ of condition ★1: a step whose in-plane normal turns by more than acos(δ) is halved. cos 20°.
  double cos_bound = 0.9396926207859084;
  /// ε of step 4 and ★2, relative: |φ_x| < ε·|∇φ| makes a point an extreme point in x.
  double extreme_tolerance = 0.02;
};

/// Where the lines lie: y = (j + offset[0])·h̃, z = (k + offset[1])·h̃ (mesher.cpp moves them when a trace fails).
using line_grid_offset = std::array<double, 2>;

/// What the trace path did, for the report (all counts over the whole job).
struct trace_stats {
  line_grid_offset line_offset{};       ///< the lines of this attempt, in units of h̃
  std::size_t grid_retries = 0;         ///< failed attempts on other line grids before this one (mesher.cpp)
  double line_spacing = 0;              ///< h̃, Å
  double step = 0;                      ///< h₁, Å
  std::size_t lines = 0;                ///< line spans (one per surviving block and line) searched for roots
  /// of those, spans whose bounds of φ prove them on one side of t0: neither sampled nor fitted (line_roots.hpp)
  std::size_t proven_lines = 0;
  std::size_t polynomial_roots = 0;     ///< roots solved from a root of the Legendre polynomial
  std::size_t bracketed_roots = 0;      ///< roots the polynomial missed, in intervals the bounds prove hold one
  /// line intervals the bounds could not decide down to a few 1e-7·h̃ (tangencies; line_roots.hpp): their roots are
  /// counted by the signs at their ends
  std::size_t tangent_root_intervals = 0;
  std::size_t arcs = 0;                 ///< traced arcs (pieces of contour between two line points)
  std::size_t polygons = 0;             ///< closed polygons of Algorithm 2 (one per surface piece in a cell)
  std::size_t extreme_points = 0;       ///< points with φ_x = 0 (step 4) kept as vertices
  std::size_t retraced_arcs = 0;        ///< arcs traced again with a smaller step after a conflict
  /// walk points kept in addition where an arc's straight edges crossed another's or its own (strip_arcs.cpp)
  std::size_t untangled_points = 0;
  /// strips whose arcs were traced at t0·(1 ± ε) because the contour at t0 crosses itself in their plane
  std::size_t level_shifted_strips = 0;
  std::size_t fallback_loops = 0;       ///< polygons triangulated with a Steiner point on the surface
  /// raw edges at an arc point shorter than a hundredth of h̃, collapsed (short_edge_collapse.hpp)
  std::size_t welded_edges = 0;
  /// refine=none only: raw edges at an arc point shorter than half of h̃, collapsed as well (trace_mesher.cpp)
  std::size_t collapsed_raw_edges = 0;
  /// cavities that no line touched, found from the lines' dips and meshed on a finer grid of their own
  /// (untouched_cavities.hpp); and those found but whose local trace failed (left out of the mesh)
  std::size_t untouched_cavities = 0;
  std::size_t untouched_cavities_left = 0;
  std::size_t field_evaluations = 0;    ///< evaluations of φ (with or without ∇φ) in roots and traces
  std::size_t raw_vertices = 0;         ///< vertices of the triangulated polygons, before any quality pass
  std::size_t raw_triangles = 0;
};

}  // namespace tracemesh
