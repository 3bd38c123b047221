#pragma once
/// @file cell_polygons.hpp
/// Algorithm 2 of TMSmesh: the closed polygons of one cell (the long box between lines (J, K), (J+1, K), (J, K+1),
/// (J+1, K+1)), walked along the arcs that its four wall strips hold, then triangulated.
///
/// Each arc is read in the direction that keeps the surface on its left seen from outside when the cell lies
/// beyond the wall (docs/method.md#orientation-from-the-walls: orientation from the walls, so the two cells of a strip always walk a shared
/// arc in opposite directions and the mesh is consistently oriented): with the canonical direction s = +1 of
/// trace_step.hpp, the cell above an xy wall (+z) and the cell below an xz wall (−y) reverse the arc. Every root on a
/// corner line then starts one arc and ends another in the cell, so the arcs chain into closed loops.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/trace/strip_arcs.hpp"
#include "core/trace/trace_lines.hpp"
#include "core/trace/trace_step.hpp"

namespace tracemesh {

/// The cell between lines (j, k), (j + 1, k), (j, k + 1), (j + 1, k + 1).
struct cell_id {
  std::int64_t j = 0, k = 0;
  friend constexpr bool operator==(const cell_id&, const cell_id&) = default;
  friend constexpr bool operator<(const cell_id& a, const cell_id& b) { return a.j < b.j || (a.j == b.j && a.k < b.k); }
};

/// Everything traced, numbered: roots are vertices 0 … lines.root_count() − 1 (line by line), then the strips'
/// interior points strip by strip (interior_first[s] is the first of strip s).
struct traced_surface {
  double spacing = 1;  ///< h̃, Å
  trace_lines lines;
  std::vector<strip_id> strips;  ///< sorted
  std::vector<strip_trace> traces;  ///< one per strip
  std::vector<std::uint32_t> interior_first;
  /// Index of `strip` in strips, or strips.size().
  std::size_t find_strip(const strip_id& strip) const;
};

/// Vertex numbers of a cell's triangles at or above this are its own Steiner points (steiner_vertex + n).
inline constexpr std::uint32_t steiner_vertex = 0x80000000u;

struct cell_mesh {
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise seen from outside
  std::vector<surface_sample> steiner;                  ///< fallback centre points on the surface
  std::size_t loops = 0;
  std::size_t fallback_loops = 0;  ///< loops triangulated by a fallback strategy (cell_polygons.cpp)
  std::size_t evaluations = 0;
  bool closed = true;  ///< false when an arc end had no partner (a root with no arc or two): the mesh would leak
  bool intersecting = false;  ///< false unless two of the cell's triangles intersect after every fallback
  /// The walls (cell_wall bits) that hold an edge of its triangles other than an arc's: a chord of a loop in that
  /// wall, made by a strategy that drops the wall rule (cell_polygons.cpp: unrestricted, in_its_plane).
  std::uint8_t wall_chords = 0;
  /// The corner lines along which such an edge runs (it lies in two walls): bit 1 << (y + 2z) for the line
  /// (j + y, k + z), y, z ∈ {0, 1}.
  std::uint8_t line_chords = 0;
};

/// Closes and triangulates the loops of `cell`. The strategies that drop the wall rule keep it on `kept_walls`
/// (cell_wall bits): a wall's chords may be made by one of its two cells only (trace_mesher.cpp), as the two would
/// otherwise lay triangles on the same edges of the wall, an edge of four triangles.
cell_mesh mesh_cell(const gaussian_field& field, const traced_surface& surface, const cell_id& cell,
                    std::uint8_t kept_walls = 0);

}  // namespace tracemesh
