#pragma once
/// @file loop_triangulation.hpp
/// Triangulation of the closed polygons of TMSmesh's Algorithm 2 (method.md §5): the loops of traced arcs on the
/// four walls of one cell (the long box parallel to x between the lines (J,K), (J+1,K), (J,K+1), (J+1,K+1)).
/// No vertex is added. The triangulation obeys the admissibility rule of docs/method.md#the-admissibility-rule, so that triangles of
/// different cells meet only along shared arc edges, and maximises the worst triangle's shape by dynamic
/// programming over sub-polygons (§7.8: the only method of the prototype that always passed; greedy ear clipping
/// failed even with the rule).
///
/// Also the band between two loops bounding a tube inside one cell (docs/method.md#tubes-inside-a-cell): triangulate_annulus.
///
/// Shape measure (1 = equilateral, 0 = degenerate), used by both:
///     q = min( shortest edge / longest edge,  4√3·area / Σ edge² )
/// The first term is the edge ratio the paper and our reports measure (method.md §6, §7.12); on its own it rates a
/// flat cap (edges 1, 1, 2 − ε) at 0.5 however flat, so the mean ratio 4√3·area/Σ edge² (the remesher's measure,
/// remesh.hpp), which falls to 0 with the area, takes over for obtuse triangles: it is the smaller term only when
/// the largest angle exceeds about 122°. For every other triangle q is exactly the edge ratio.
///
/// Thread safety: the functions are reentrant; the dynamic programmes keep their O(n²) buffers in one thread_local
/// workspace per thread, which holds buffers only (never state that changes a result).

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "core/vec3.hpp"

namespace tracemesh {

/// Wall planes of a cell, as bits of loop_vertex::planes.
enum cell_wall : std::uint8_t { wall_y_low = 1, wall_y_high = 2, wall_z_low = 4, wall_z_high = 8 };

/// One vertex of a loop.
struct loop_vertex {
  vec3 position;            ///< Å, on the surface
  vec3 normal;              ///< outward unit surface normal there (−∇φ/|∇φ|)
  std::uint8_t planes = 0;  ///< the cell walls the vertex lies on: 1 bit for an arc's interior point, 2 for a root on a line
};

/// The rules' thresholds. The defaults keep a margin of 10³ over the certificate's degeneracy rules
/// (core/analysis/mesh_analysis.hpp: degenerate_edge_length = 1e-9 Å, degenerate_area_ratio = 1e-12).
struct loop_triangulation_settings {
  /// Rule 2 (orientation): a triangle a, b, c is kept only when the cosine of the angle between its face normal
  /// cross(b − a, c − a) and n_a + n_b + n_c exceeds this. 0.05 (the face may lean up to ≈ 87° from the averaged
  /// surface normal): a positive margin so that rounding cannot accept a face that is flat against the normals,
  /// small enough to accept the strongly tilted faces of loops on tightly curved surface (h̃ ≈ atom radius).
  /// A negative value accepts faces leaning beyond 90° (cos > value); a value ≤ −1 turns rule 2 off (fallbacks only:
  /// the orientation then rests on the loop order alone, but for its floor: no face against all three corners).
  double min_normal_cosine = 0.05;
  /// Rule 3: every edge at least this long (Å).
  double min_edge_length = 1e-6;
  /// Rule 3: area at least this × (longest edge)².
  double min_area_ratio = 1e-9;
  /// Objective: false maximises the worst shape q (above); true maximises the worst agreement between each face's
  /// normal and its corners' field normals, (1 + cos)/2 — the triangulation that lies flattest on the surface, for
  /// loops whose best-shaped triangulation folds over itself (a fallback of the trace path).
  bool maximise_normal_agreement = false;
  /// triangulate_loop_in_its_plane only: walls (cell_wall bits) on which it keeps the wall rule, cutting no ear whose
  /// new edge joins two vertices on one of them (cell_polygons.cpp: the walls whose chords belong to the neighbour).
  std::uint8_t kept_walls = 0;
};

/// The shape measure q of triangle a, b, c described in the file comment, in [0, 1]; 0 when an edge has zero
/// length or a coordinate is not finite.
double triangle_quality(const vec3& a, const vec3& b, const vec3& c);

/// Triangulates the closed polygon `loop` of Algorithm 2 without new vertices.
/// @param loop   n ≥ 3 vertices, no vertex repeated, in the order that is counter-clockwise seen from outside (from
///               the side the normals point to). Not required to be planar or convex.
/// @param out    receives n − 2 triangles as indices into `loop`, appended; each is (i, k, j) with i < k < j, i.e.
///               in loop order, hence counter-clockwise seen from outside like the loop.
/// @return the worst q of the triangles appended; none, appending nothing, when n < 3 or no triangulation
///         satisfies every rule:
///  1. admissibility (docs/method.md#the-admissibility-rule): no triangle has its three corners on one common wall
///     ((a.planes & b.planes & c.planes) != 0); no edge joins two vertices that share a wall unless they are
///     consecutive on the loop (the loop's own edges are always allowed);
///  2. orientation: dot(cross(b − a, c − a), n_a + n_b + n_c) > settings.min_normal_cosine · |cross| · |Σn|
///     (skipped when min_normal_cosine ≤ −1), and never a face with dot(cross, n) < 0 at all three corners (a fold:
///     kept when rule 2 is relaxed or off);
///  3. not degenerate: every edge ≥ settings.min_edge_length (loop edges included: a shorter loop edge makes the
///     loop fail) and area ≥ settings.min_area_ratio · longest edge².
/// Among the triangulations satisfying the rules it returns one that maximises the worst triangle's q and, among
/// those, the sum of q (exactly: two passes of dynamic programming over the sub-polygons (i, j) — the first finds
/// the optimal worst quality q*, the second maximises the sum over triangulations whose triangles all reach q*,
/// up to a relative 1e-12). Remaining ties go to the smaller apex index, so the result is deterministic.
/// Cost: O(n³) time (each candidate triangle evaluated at most twice, most pruned by the bounds), O(n²) memory in
/// the thread's workspace (≈ 37·n² bytes), no allocation once the workspace and `out` have grown. Measured CPU
/// time per loop (Release, one core of a shared 2.4 GHz AMD EPYC, loops of cells on a smooth surface): n = 4:
/// 0.13–0.15 µs, 6: 0.3–0.5 µs, 12: 1.5–2.5 µs, 50: 25–75 µs, 200: 0.7–1.4 ms (a long zigzag along x) to 2–3 ms
/// (points 0.02 Å apart).
std::optional<double> triangulate_loop(std::span<const loop_vertex> loop,
                                       std::vector<std::array<std::uint32_t, 3>>& out,
                                       const loop_triangulation_settings& settings = {});

/// Triangulates the band (annulus) between two loops that together bound one piece of surface inside a cell — a
/// tube (docs/method.md#tubes-inside-a-cell) — without new vertices. The two loops play symmetric roles.
/// @param outer, inner  the two loops, p ≥ 3 and q ≥ 3 vertices, no vertex repeated or shared. Each is oriented
///               like a loop of triangulate_loop, with the surface piece on its left seen from outside: counter-
///               clockwise seen from outside, so the two are traversed in opposite senses around the tube's axis.
/// @param out    receives p + q triangles, appended, as indices into the concatenation outer ++ inner (outer
///               vertex a is a, inner vertex b is p + b), counter-clockwise seen from outside. Every triangle joins
///               a loop edge of one loop to a vertex of the other (a "band"); each loop edge is used once.
/// @return the worst q of the band; none, appending nothing, when a loop has fewer than 3 vertices or no band
///         satisfies the rules of triangulate_loop (an edge joining the two loops counts as a non-loop edge: its
///         ends may share no wall). Band triangulations only: a tube whose band breaks the rules (e.g. both
///         loops on one wall) needs new vertices, which is the caller's business.
/// Optimum as for triangulate_loop: worst q maximised, then Σ q, over every band. Cost: O(p·q) triangle
/// evaluations and O(p·q·min(p, q)) table steps, O(p·q) memory; measured 2.4–2.9 µs for 6 + 6 vertices,
/// 10–12 µs for 12 + 12, 0.2–0.3 ms for 50 + 40.
std::optional<double> triangulate_annulus(std::span<const loop_vertex> outer, std::span<const loop_vertex> inner,
                                          std::vector<std::array<std::uint32_t, 3>>& out,
                                          const loop_triangulation_settings& settings = {});

/// Triangulates a loop that lies almost in one plane by ear clipping in that plane: the loop is projected along its
/// Newell normal (the normal of its best plane, pointing to the side it is counter-clockwise from), and when the
/// projection is a simple polygon, the ear of best q is cut off until three vertices are left. The triangles'
/// projections then do not overlap, so the triangles cannot cross each other, whatever the loop's folds in 3-D —
/// which no rule of triangulate_loop ensures for a loop that doubles back on itself within a wall (a hairpin of the
/// contour at a sharp kernel, where every triangulation the dynamic programme prefers folds over itself). Neither
/// the wall rule (but on settings.kept_walls) nor the orientation rule applies but for the latter's floor (no face
/// against the normals at all three corners); a triangle must not be degenerate (area ≥ settings.min_area_ratio ×
/// longest edge², edges ≥ settings.min_edge_length).
/// @param out  receives n − 2 triangles as indices into `loop`, each in the loop's cyclic order, hence oriented like
///             the loop.
/// @return false, appending nothing, when n < 3, the projection is not simple, or some step has no acceptable ear.
bool triangulate_loop_in_its_plane(std::span<const loop_vertex> loop, std::vector<std::array<std::uint32_t, 3>>& out,
                                   const loop_triangulation_settings& settings = {});

}  // namespace tracemesh
