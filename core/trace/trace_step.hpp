#pragma once
/// @file trace_step.hpp
/// The trace step of TMSmesh (paper Algorithm 1): from a surface point on one line, walk along the planar contour
/// {φ = t0} ∩ plane until it crosses one of the two lines bounding the strip, and return the crossing together with
/// the points walked through and the extreme points met on the way.
///
/// A plane is {p : p[normal_axis] = offset} with normal_axis 2 (an xy plane, z fixed) or 1 (an xz plane, y fixed);
/// its in-plane coordinates are (x, v) with v = p[3 − normal_axis]. Lines are v = v_low and v = v_high (= v_low + h̃).
/// With g = (φ_x, φ_v) the in-plane gradient, the contour's tangent is s·(−φ_v, φ_x); s = +1 is the arc's
/// *canonical* direction (the cell on the −z side of an xy wall, and on the +y side of an xz wall, walks its
/// boundary that way: see trace_mesher.cpp).

#include <cstddef>
#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/trace/trace_lines.hpp"
#include "core/trace/trace_parameters.hpp"
#include "core/vec3.hpp"

namespace tracemesh {

struct trace_plane {
  int normal_axis = 2;  ///< 2: xy plane (z = offset); 1: xz plane (y = offset)
  double offset = 0;    ///< Å
  /// The contour traced is {φ = t0 + level_shift}: 0 but for a strip whose contour crosses itself at t0
  /// (strip_arcs.cpp, level-shifted retrace).
  double level_shift = 0;
  int v_axis() const { return 3 - normal_axis; }
};

/// A point on the surface with the field's gradient there (3-D ∇φ).
struct surface_sample {
  vec3 position;
  vec3 gradient;
  bool extreme = false;  ///< |φ_x| < ε·|∇φ_in-plane| (Algorithm 1, step 4): the contour runs along x here
};

/// Where a traced arc ended.
enum class trace_end {
  low_line,   ///< crossed v = v_low
  high_line,  ///< crossed v = v_high
  failed,     ///< no acceptable step (step below the minimum, or too many steps)
};

struct traced_arc {
  std::vector<surface_sample> points;  ///< from the start to the crossing, both included; the crossing lies on its line
  trace_end end = trace_end::failed;
};

/// Limits of one trace.
struct trace_step_settings {
  double v_low = 0, v_high = 1;  ///< the strip's two lines, Å
  double max_step = 0.5;         ///< h₁, Å
  double first_step = 0.5;       ///< Å, the first step's first try (≤ max_step; smaller beside a close root)
  double cos_bound = 0.94;       ///< δ (★1)
  double extreme_tolerance = 0.02;  ///< ε (step 4 and ★2), relative to |∇φ| in the plane
  double min_step = 1e-7;        ///< Å: a step halved below this fails the trace
  /// Å: the corrector stops this close to the contour (step 3). The points the mesh keeps are polished to 1e-11 Å
  /// afterwards (strip_arcs.cpp); a walk point only needs to be close enough for the next prediction.
  double corrector_tolerance = 1e-5;
  /// Å: a corrector update shorter than this ends the correction without a further evaluation (one evaluation per
  /// step where the prediction was good; the point is then within ~curvature × blind_step² of the contour). The
  /// point keeps the gradient of the point before the update: blind_step_for(d) keeps that gradient close.
  double blind_step = 2e-3;
  /// A cheaper approximation of the field (a looser cutoff, gaussian_field's `tolerance`) to walk on; null walks on
  /// the exact field. Crossings and kept points are always solved on the exact field, and so is every walk point
  /// that lands within exact_near_line of a line (or past it), where crossings and near-tangencies are decided.
  const gaussian_field* walk_field = nullptr;
  double exact_near_line = 0.05;  ///< Å
  std::size_t max_steps = 100000;   ///< bounds the walk (a closed contour that never meets a line)
  /// The known roots of each line, ascending in x: a step that passes over one close to its line is shortened, and
  /// a crossing that has exactly one of them nearby is that root (no polishing; see trace_contour).
  std::span<const line_point> low_roots, high_roots;
};

/// trace_step_settings::blind_step for kernels of decay rate d: 2e-3 Å at d = −1 and below that as the kernels
/// sharpen. A blind update reuses the gradient of the point before it, which is off by about |H|·length, and a
/// kernel's |H| / |∇| near its surface grows as (1 − 2d) / r. At d = −20, where a plane was nearly tangent to the
/// surface, an update under 2e-3 Å left a walk point with an in-plane gradient 12° from its own and φ_x of the
/// other sign, and ★2, comparing it with fresh gradients, refused every step down to min_step. Scaled so, the stale
/// gradient is as close as at d = −1.
double blind_step_for(double d);

/// Traces from `start` (on the surface, on line v_low or v_high) into the strip along s·(−φ_v, φ_x), s = ±1
/// (Algorithm 1). Each step predicts along the unit tangent (step 2), corrects by Newton along the in-plane
/// gradient back onto the contour (step 3), records extreme points (step 4), halves on ★1 (normal turned by more
/// than acos δ) or ★2 (φ_x changed sign between two points where |φ_x| > ε|g|, so an extreme point was jumped
/// over), and stops at the first segment that reaches a line (step 6); the crossing is interpolated and then
/// polished onto the line by Newton in x, unless a known root of that line is the only one near the interpolated
/// crossing: the walk then arrives at that root (already polished on the exact field), and the Newton iterations are
/// saved. A step that would cross back over the start line at the start point itself is halved. Steps grow back
/// towards h₁ by doubling after each accepted step. `evaluations` is increased by the number of field evaluations made.
traced_arc trace_contour(const gaussian_field& field, const trace_plane& plane, const surface_sample& start, int sign,
                         const trace_step_settings& settings, std::size_t& evaluations);

/// As above, walking through `walk`: a neighbourhood of settings.walk_field (of `field` when that is null) whose
/// boxes are flat along the plane's normal (trace_neighbourhood_reach), which the traces of one plane may share. The
/// same arc, bit for bit, with fewer cell look-ups. The exact field's few evaluations of a walk on another field
/// (crossings, points near a line) are made on `field` directly: they would not repay a gather of their own.
traced_arc trace_contour(const gaussian_field& field, field_neighbourhood& walk, const trace_plane& plane,
                         const surface_sample& start, int sign, const trace_step_settings& settings,
                         std::size_t& evaluations);

/// Half size of the neighbourhood boxes of the traces, in steps h₁: a box serves a few steps before the walk
/// leaves it, and it grows the atoms screened per evaluation by less than the cell rows it replaces do.
inline constexpr double neighbourhood_reach_steps = 3;
/// The reach (field_neighbourhood) of a trace in `plane` with steps of at most `max_step` Å: 0 along the normal.
vec3 trace_neighbourhood_reach(const trace_plane& plane, double max_step);

/// Newton in x on the line (v fixed) from `guess` (on the plane): the root of φ = t0 + level_shift within
/// `max_move` Å of the guess, with its gradient. False when it does not converge to 1e-12·t0 (or 1e-11 Å).
/// `Field`: const gaussian_field, or field_neighbourhood (the same values; defined for these two).
template <class Field>
bool polish_on_line(Field& field, vec3 guess, double max_move, surface_sample& out, std::size_t& evaluations,
                    double level_shift = 0);

/// Newton along the in-plane gradient (the plane's coordinate unchanged) from p onto {φ = t0 + plane.level_shift},
/// to `tolerance` Å (first-order distance |φ − t0| / |∇φ|). A Newton update shorter than `blind_step` Å is applied
/// without evaluating the field again (the result's gradient is then that of the point before the update). False
/// when it does not converge within `max_move` Å. `Field`: as polish_on_line.
template <class Field>
bool correct_in_plane(Field& field, const trace_plane& plane, vec3 p, double max_move, surface_sample& out,
                      std::size_t& evaluations, double tolerance = 1e-11, double blind_step = 0);

}  // namespace tracemesh
