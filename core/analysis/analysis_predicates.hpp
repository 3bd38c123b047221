#pragma once
/// @file analysis_predicates.hpp
/// Exact orientation predicates on double coordinates, for the self-intersection test of mesh_analysis.
/// Each predicate first evaluates its determinant in floating point with a forward error bound (Shewchuk's
/// "stage A" bound, rounded up); only when the bound cannot certify the sign is the determinant recomputed
/// exactly with expansion arithmetic (error-free sums and products). The sign returned is the sign of the exact
/// determinant of the given doubles, provided no intermediate product overflows or underflows: true for
/// |coordinates| ≤ max_analysed_coordinate (mesh_analysis.hpp) whose pairwise differences, when not 0, exceed ~1e-90.

namespace tracemesh {
struct vec3;
}

namespace tracemesh::detail {

/// Sign (−1, 0, +1) of det[b − a, c − a, p − a] = dot(cross(b − a, c − a), p − a): +1 when p lies on the side of
/// the plane (a, b, c) that the counter-clockwise normal of a, b, c points to, 0 when the four points are coplanar.
int orient3d(const vec3& a, const vec3& b, const vec3& c, const vec3& p);

/// Sign of det[b − a, c − a] for 2-D points (ax, ay) …: +1 when a, b, c turn counter-clockwise, 0 when collinear.
int orient2d(double ax, double ay, double bx, double by, double cx, double cy);

}  // namespace tracemesh::detail
