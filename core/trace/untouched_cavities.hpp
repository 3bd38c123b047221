#pragma once
/// @file untouched_cavities.hpp
/// Cavities that no line touches (docs/method.md#loops-that-touch-no-line): a void of φ < t0 that fits between the lines of the grid has no
/// root on any line, so Algorithm 2 never sees it. It is found from the lines themselves, proven with the bounds of
/// stage one, and handed back as a box that holds it and nothing else, for the trace path to mesh on a finer grid
/// of its own (trace_mesher.cpp):
///  1. *Seeds*: a line that passes near such a void shows a dip of φ towards t0 between its samples
///     (line_root_settings::dip_ratio; block_line_roots::dips).
///  2. *Minimum*: from each seed, a descent of φ in 3-D (BFGS with a backtracking line search). A minimum below t0
///     is a pocket of the outside of the surface.
///  3. *Extent*: from the minimum along ±x, ±y, ±z to where φ reaches t0 again. A pocket that reaches further than
///     untouched_cavity_settings::max_extent × h̃ along some axis is not a small void (an open groove, a tunnel).
///  4. *Untouched*: no root of the job's lines lies in the pocket's reach, nor in the box below (the main mesh has
///     no piece there).
///  5. *Proof*: a box centred on the minimum, a margin wider than the extent, whose six faces the lower bound of
///     eqs. 3–5 puts above t0 (faces sampled first, then cut adaptively into patches until each is proven). The
///     surface then cannot cross the faces: every piece of it that enters the box lies wholly inside. A box that
///     holds the minimum of an earlier one (or whose minimum an earlier one holds) is dropped.
/// The box is whole blocks of a local grid with one line through the minimum and one more on each side inside the
/// void, so that the trace meets the void however small it is.
/// Deterministic: seeds are descended independently and the minima taken in a fixed order.

#include <cstddef>
#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/progress.hpp"
#include "core/trace/trace_lines.hpp"

namespace tracemesh {

struct untouched_cavity_settings {
  /// Seeds: line samples where φ dips to at most this × t0 (line_root_settings::dip_ratio).
  double dip_ratio = 1.5;
  /// A pocket reaching further than this × h̃ from its minimum along an axis is not a void between lines.
  double max_extent = 2.0;
  /// The box's half width over the pocket's extent along the axis (the first try; grown by box_growth on a
  /// failed proof, at most box_tries times).
  double box_margin = 1.5;
  double box_growth = 1.5;
  int box_tries = 3;
  /// Spacing of the local grid: this × the pocket's narrowest reach ρ in y and z, at most max_local_spacing × h̃.
  /// The lines at 0 and ±0.85ρ from the minimum cross the void, clear of the tangency at its extreme points (±ρ:
  /// a line there touches the void, a double root). Finer grids give the tiny void many more vertices that the
  /// quality pass cannot remove (docs/method.md, stage 7).
  double local_spacing = 0.85;
  double max_local_spacing = 0.5;
};

/// A void to mesh: the box, proven to hold all of it and no other surface, and the local grid inside it.
struct untouched_cavity {
  vec3 minimum;          ///< where φ is lowest (φ < t0)
  /// Centred on the minimum in y and z, φ > t0 on its faces (eqs. 3–5). It is blocks_x × blocks_yz × blocks_yz
  /// lattice blocks of the local grid, whose lines lie at y = box.lo.y + j·spacing, z = box.lo.z + k·spacing: line
  /// (4·blocks_yz, 4·blocks_yz) passes through the minimum.
  box3 box;
  double spacing = 0;  ///< the local grid's line spacing, Å
  int blocks_x = 1;
  int blocks_yz = 1;
};

struct untouched_cavity_stats {
  std::size_t seeds = 0;             ///< line dips descended from
  std::size_t pockets = 0;           ///< distinct minima below t0
  std::size_t field_evaluations = 0;  ///< φ or ∇φ evaluations (descents, extents; face bounds not counted)
};

/// The untouched cavities of the surface whose lines (spacing h̃ = `spacing`) are `lines`, from the line dips
/// `seeds`. Returns an empty list when `progress` is cancelled (the caller checks the token).
std::vector<untouched_cavity> find_untouched_cavities(const gaussian_field& field, const trace_lines& lines,
                                                      double spacing, std::span<const vec3> seeds,
                                                      const untouched_cavity_settings& settings,
                                                      progress_token& progress, untouched_cavity_stats& stats);

/// True when the lower bound of eqs. 3–5 puts φ above t0 everywhere on the six faces of `box`: each face is cut
/// into patches, and a patch whose bound does not prove it is cut in four, down to patches `min_patch` Å wide.
bool box_faces_above_level(const gaussian_field& field, const box3& box, double min_patch);

}  // namespace tracemesh
