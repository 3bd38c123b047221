#pragma once
/// @file analysis_self_intersection.hpp
/// The broad phase of count_self_intersections for pairs of triangles that share no vertex: a sparse uniform grid
/// over triangle bounding boxes (pairs that share a vertex are handled fan by fan, see analysis_fan_pairs.hpp).
///
/// Each triangle is entered in every cell its (single-precision, outward-rounded) bounding box overlaps; the
/// (cell, triangle) entries are packed into 64-bit integers and radix-sorted so that each cell's triangles are
/// contiguous; within a cell, pairs of overlapping boxes are found by testing all pairs (or a sweep along x in
/// crowded cells). A pair is tested only in the cell that holds the lowest corner of the intersection of the two
/// boxes, so it is tested exactly once however many cells both boxes share. Cells are processed in parallel; the
/// count (an integer) does not depend on the schedule.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/analysis/analysis_geometry.hpp"
#include "core/mesh.hpp"

namespace tracemesh::detail {

/// Grid cell edge relative to the mean bounding-box extent of the triangles: about three cells per triangle.
inline constexpr double grid_cell_factor = 2.0;
/// Grid entries allowed per tested triangle (plus a constant); past it the cell size doubles. Bounds memory when a
/// few triangles are huge compared with the mean.
inline constexpr std::size_t max_grid_entries_per_triangle = 16;

/// Counts the intersecting pairs among triangles with defects[t] == none that share no vertex.
std::size_t count_intersecting_separate_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects);

/// Two triangle indices, the smaller first.
using triangle_pair = std::array<std::uint32_t, 2>;

/// Which pairs need no test: `groups`, when not empty, has one entry per triangle, 0 for a triangle to test against
/// all, k > 0 for one of a group known not to meet itself (checked before, e.g. the fixed triangles around a patch).
struct known_apart_groups {
  const std::vector<std::uint8_t>& groups;
  bool operator()(std::uint32_t s, std::uint32_t t) const {
    return !groups.empty() && groups[s] != 0 && groups[s] == groups[t];
  }
};

/// Appends `part` to `pairs` (the combine step of the pair searches' deterministic_reduce).
inline std::vector<triangle_pair> append_pairs(std::vector<triangle_pair> pairs, const std::vector<triangle_pair>& part) {
  pairs.insert(pairs.end(), part.begin(), part.end());
  return pairs;
}
/// Cells or vertices per chunk of the pair searches: patches of the quality pass hold a few thousand cells, and
/// analysis_chunk_size would leave one core idle on them.
inline constexpr std::size_t pair_search_chunk = 1024;

/// The pairs count_intersecting_separate_pairs counts, but those `groups` says are apart, in an order that does not
/// depend on the thread count.
std::vector<triangle_pair> find_intersecting_separate_pairs(const surface_mesh& mesh,
                                                            const std::vector<triangle_defect>& defects,
                                                            const std::vector<std::uint8_t>& groups);

}  // namespace tracemesh::detail
