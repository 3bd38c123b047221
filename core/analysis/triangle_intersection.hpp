#pragma once
/// @file triangle_intersection.hpp
/// Exact intersection tests between two closed triangles of a mesh, built on the exact orientation predicates of
/// analysis_predicates.hpp (so the answers do not depend on rounding). Preconditions everywhere: every triangle is
/// non-degenerate (its corners are not collinear) and |coordinates| ≤ max_analysed_coordinate.
///
/// The tests rest on one fact: two closed non-degenerate triangles meet if and only if an edge of one meets the
/// other triangle (their intersection, when not empty, is a segment or polygon whose extreme points lie on edges).

#include <array>
#include <cstdint>
#include <vector>

#include "core/vec3.hpp"

namespace tracemesh::detail {

using triangle_corners = std::array<vec3, 3>;

/// A point of a plane, expressed in two coordinates (e.g. those left after dropping one axis).
struct point2 {
  double x, y;
};

/// True when closed segments [a, b] and [c, d] of one plane have a common point (touching counts), exactly.
bool segments_intersect_2d(const point2& a, const point2& b, const point2& c, const point2& d);

/// True when closed triangles t and u have at least one common point (touching counts).
bool triangles_intersect(const triangle_corners& t, const triangle_corners& u);

/// Triangles (v, a, b) and (v, c, d) share the corner v: true when they have a common point other than v.
bool triangles_meet_beyond_shared_vertex(const vec3& v, const vec3& a, const vec3& b, const vec3& c, const vec3& d);

/// Triangles (p, q, a) and (p, q, b) share the edge pq (whatever their orientations): true when they fold onto
/// each other, i.e. lie in one plane with a and b on the same side of pq.
bool triangles_fold_over_shared_edge(const vec3& p, const vec3& q, const vec3& a, const vec3& b);

/// Whether triangles t and u of a mesh (vertex indices into `positions`, three distinct indices each) count as a
/// self-intersection: sharing no vertex, any contact; sharing one vertex, a common point other than it; sharing an
/// edge, folding onto each other; sharing all three vertices (a duplicated face), always.
bool mesh_triangles_intersect(const std::vector<vec3>& positions, const std::array<std::uint32_t, 3>& t,
                              const std::array<std::uint32_t, 3>& u);

}  // namespace tracemesh::detail
