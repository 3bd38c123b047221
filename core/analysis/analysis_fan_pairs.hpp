#pragma once
/// @file analysis_fan_pairs.hpp
/// The self-intersection test for pairs of triangles that share a vertex (the vast majority of nearby pairs in a
/// mesh), done vertex by vertex over the triangles around it.
///
/// Most fans are proved free of intersections as a whole, with exact predicates: if, seen along a coordinate axis,
/// the triangles around v all turn the same way and their angular sectors wind around v exactly once, then the
/// projection is one-to-one away from v and the shared edges, so no two of these triangles meet anywhere else.
/// Only the pairs of the other fans are tested one by one (quadratic in their valence: cheap for the small fans of
/// real meshes, slow only for vertices shared by thousands of triangles that do not form a proper star).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_self_intersection.hpp"
#include "core/analysis/analysis_topology.hpp"
#include "core/mesh.hpp"

namespace tracemesh::detail {

/// True when the triangles around `vertex` (its fan, `around`) are proved pairwise free of intersections beyond
/// their shared vertex and edges: a closed, consistently oriented fan of tested triangles whose projection along
/// some axis is a star winding once around the vertex. False means "not proved", not "intersecting".
bool fan_is_embedded_star(const surface_mesh& mesh, const std::vector<triangle_defect>& defects, std::uint32_t vertex,
                          std::span<const std::uint32_t> around);

/// Counts the intersecting pairs (mesh_triangles_intersect) of tested triangles (defect none) that share at least
/// one vertex. Each pair is considered once, in the fan of the smallest vertex it shares.
std::size_t count_intersecting_fan_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                         const vertex_fans& fans);

/// The pairs count_intersecting_fan_pairs counts, but those `groups` says are apart (known_apart_groups), in an
/// order that does not depend on the thread count.
std::vector<triangle_pair> find_intersecting_fan_pairs(const surface_mesh& mesh,
                                                       const std::vector<triangle_defect>& defects,
                                                       const vertex_fans& fans, const std::vector<std::uint8_t>& groups);

/// Every pair {i, j} (i < j, sorted) of triangles without defect that count as a self-intersection (see
/// count_self_intersections). `defects`: classify_triangles(mesh). `groups`, when not empty, has one entry per
/// triangle: 0 for a triangle to test against all, k > 0 for one of a group known not to meet itself (checked
/// before); pairs within one such group are not tested. Grid-accelerated and parallel; the result does not depend on
/// the thread count.
std::vector<triangle_pair> find_intersecting_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                                   const std::vector<std::uint8_t>& groups = {});

}  // namespace tracemesh::detail
