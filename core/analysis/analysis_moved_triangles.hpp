#pragma once
/// @file analysis_moved_triangles.hpp
/// The certificate's geometric tests on the part of a mesh that an edit changed: the triangles it moved or made,
/// tested against each other and against every triangle whose bounding box meets theirs. The other triangles were
/// tested before and did not move, so this is the whole certificate's verdict on the edit at a fraction of its cost.

#include <cstdint>
#include <vector>

#include "core/mesh.hpp"

namespace tracemesh::detail {

/// The triangles of `moving` (indices into mesh.triangles; each live) that are degenerate or ill-formed
/// (classify_triangles) or meet another live triangle (find_intersecting_pairs), sorted. `alive` is empty (every
/// triangle live) or holds one entry per triangle, 0 for a removed one, which is ignored.
std::vector<std::uint32_t> failing_moved_triangles(const surface_mesh& mesh, const std::vector<char>& alive,
                                                   std::vector<std::uint32_t> moving);

/// As failing_moved_triangles, after a test of the same mesh in which the triangles of `moving` that are not in
/// `retest` had the same corners and passed, and every live triangle not in `retest` had the same corners: only the
/// pairs with a triangle of `retest` are tested. Returns the triangles of `moving` that are degenerate or meet
/// another live triangle, sorted (an edit made again with a few changes, as a round of short-edge collapses).
std::vector<std::uint32_t> failing_moved_triangles_again(const surface_mesh& mesh, const std::vector<char>& alive,
                                                         std::vector<std::uint32_t> moving,
                                                         std::vector<std::uint32_t> retest);

/// The live triangles whose bounding boxes meet those of `moving` (`moving` included), sorted.
std::vector<std::uint32_t> triangles_near(const surface_mesh& mesh, const std::vector<char>& alive,
                                          const std::vector<std::uint32_t>& moving);

/// As failing_moved_triangles, but each triangle of `moving` is tested only against the others of `moving` and
/// against `others` (no search of the mesh): for a second look after some edits were undone, `others` being the
/// triangles the undoing restored (they passed the certificate before, but not against the edits kept).
std::vector<std::uint32_t> failing_moved_triangles_among(const surface_mesh& mesh, std::vector<std::uint32_t> moving,
                                                         const std::vector<std::uint32_t>& others);

}  // namespace tracemesh::detail
