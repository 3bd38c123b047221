#pragma once
/// @file remesh_intersections.hpp
/// Which triangles of a mesh intersect: the remesher needs the offending pairs (not just their number, as
/// count_self_intersections in mesh_analysis.hpp gives) to know where to freeze the mesh.
///
/// The tests are conservative: triangles closer than `tolerance` count as intersecting, so rounding can only add
/// pairs, never hide one.

#include <array>
#include <cstdint>
#include <vector>

#include "core/detail/remesh_mesh.hpp"
#include "core/vec3.hpp"

namespace tracemesh::detail {

/// Default distance (Å) under which two triangles count as touching.
inline constexpr double intersection_tolerance = 1e-7;

using triangle_pair = std::array<std::uint32_t, 2>;

/// Does segment p–q meet triangle (a, b, c) or pass within `tolerance` of it (in most configurations; a proper
/// crossing is always found)? A degenerate triangle counts as met.
bool segment_meets_triangle(const vec3& p, const vec3& q, const vec3& a, const vec3& b, const vec3& c,
                            double tolerance);

/// Do triangles `a` and `b`, which share no vertex, intersect?
bool triangles_intersect(const std::array<vec3, 3>& a, const std::array<vec3, 3>& b, double tolerance);

/// Do triangles (v, a1, a2) and (v, b1, b2), which share only the vertex v, meet anywhere but at v? (Their
/// intersection is convex and contains v, so it is more than v exactly when a1–a2 meets the second triangle or
/// b1–b2 meets the first.)
bool triangles_meet_beyond_vertex(const vec3& v, const vec3& a1, const vec3& a2, const vec3& b1, const vec3& b2,
                                  double tolerance);

/// Every pair {i, j} (i < j, sorted) of triangles that intersect, following the certificate's rule: pairs sharing no
/// vertex that intersect, plus pairs sharing exactly one vertex that meet elsewhere; pairs sharing an edge are
/// not tested. Grid-accelerated and parallel; the result does not depend on the thread count.
std::vector<triangle_pair> find_intersecting_pairs(const std::vector<vec3>& positions, const triangle_list& triangles,
                                                   double tolerance = intersection_tolerance);

}  // namespace tracemesh::detail
