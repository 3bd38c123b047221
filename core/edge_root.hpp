#pragma once
/// @file edge_root.hpp
/// Surface points on lattice edges (paper §3 finds them on x-parallel lines; here every cut edge of the
/// tetrahedral lattice gets one): the root of φ = t0 between an inside and an outside end point.

#include "core/gaussian_field.hpp"

namespace tracemesh {

/// Fraction kept between a root and an edge's end points, so no two vertices of a tetrahedron coincide.
inline constexpr double edge_root_margin = 1e-4;

/// The point of segment a→b where φ = t0, given that exactly one of a, b is inside (φ ≥ t0): Newton steps on the exact
/// field along the segment, safeguarded by bisection so the bracket always shrinks; converges to ≤ 1e-12 of the
/// segment. The result is kept within [margin, 1 − margin] of the segment.
vec3 solve_edge_root(const gaussian_field& field, const vec3& a, const vec3& b, bool a_inside);

}  // namespace tracemesh
