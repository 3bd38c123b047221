#pragma once
/// @file strip_arcs.hpp
/// The arcs of one strip: the pieces of the contour {φ = t0} ∩ plane between two neighbouring lines of that plane,
/// each traced once from a root (Algorithm 1) and stored with the strip, so that both cells beside the strip read
/// the same arc (method.md §7.1). Every root on either line is the end of exactly one arc of the strip.

#include <cstdint>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/trace/trace_lines.hpp"
#include "core/trace/trace_step.hpp"

namespace tracemesh {

/// A strip between line (j, k) and its neighbour: (j + 1, k) in the xy plane z = k·h̃, or (j, k + 1) in the xz plane
/// y = j·h̃.
struct strip_id {
  int orientation = 0;  ///< 0: xy strip, 1: xz strip
  std::int64_t j = 0, k = 0;
  line_id low_line() const { return {j, k}; }
  line_id high_line() const { return orientation == 0 ? line_id{j + 1, k} : line_id{j, k + 1}; }
  friend constexpr bool operator==(const strip_id&, const strip_id&) = default;
  friend constexpr bool operator<(const strip_id& a, const strip_id& b) {
    if (a.orientation != b.orientation) return a.orientation < b.orientation;
    return a.j < b.j || (a.j == b.j && a.k < b.k);
  }
};

/// One end of an arc: a root on the strip's low (0) or high (1) line, known by its x.
struct arc_end {
  int side = 0;
  double x = 0;
};

/// An arc in its canonical direction (tangent +(−φ_v, φ_x), trace_step.hpp): start, interior points, end.
struct strip_arc {
  arc_end start, end;
  std::uint32_t first_interior = 0;  ///< into strip_trace::interior
  std::uint32_t interior_count = 0;
};

struct strip_trace {
  std::vector<strip_arc> arcs;
  std::vector<surface_sample> interior;  ///< the arcs' kept interior points, arc after arc
  std::size_t evaluations = 0;
  std::size_t extreme_points = 0;  ///< kept interior points with φ_x ≈ 0
  std::size_t retraced = 0;        ///< arcs traced again with a smaller step after a failure or conflict
  std::size_t failures = 0;        ///< roots left without an arc (the mesh cannot close: an error later)
  std::size_t untangled_points = 0;  ///< kept points added where the arcs' straight edges crossed (untangle_arcs)
  std::size_t unpolished = 0;      ///< kept points left as the walk put them (within the corrector's tolerance)
  /// The arcs were traced at a level t0·(1 ± ε) next to t0, the contour at t0 crossing itself in the strip's plane
  /// (strip_arcs.cpp, level_shifts); their points lie on φ = t0, their ends are the lines' roots.
  bool level_shifted = false;
};

struct strip_settings {
  double spacing = 1;          ///< h̃, Å
  double max_step = 0.5;       ///< h₁, Å
  double cos_bound = 0.94;     ///< δ
  double extreme_tolerance = 0.02;  ///< ε
  double resample_spacing = 1;  ///< Å: kept interior points are about this far apart along the arc (§7.7)
  const gaussian_field* walk_field = nullptr;  ///< see trace_step_settings::walk_field
};

/// The strips beside the lines of `lines` (four per line, each once), sorted: those that can hold an arc.
std::vector<strip_id> strips_beside(const trace_lines& lines);

/// Traces every arc of `strip` from the roots of its two lines in `lines`.
strip_trace trace_strip(const gaussian_field& field, const trace_lines& lines, const strip_id& strip,
                        const strip_settings& settings);

}  // namespace tracemesh
