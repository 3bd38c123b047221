#pragma once
/// @file remesh_geometry.hpp
/// Small geometric measures shared by the remesher's operations and checks.

#include <cmath>
#include <cstddef>

#include "core/field/gaussian_field.hpp"
#include "core/vec3.hpp"

namespace tracemesh::detail {

/// (b − a) × (c − a): twice the area times the unit normal of the counter-clockwise triangle (a, b, c).
inline vec3 area_vector(const vec3& a, const vec3& b, const vec3& c) { return cross(b - a, c - a); }

/// Shape quality 4√3·area / (|ab|² + |bc|² + |ca|²): 1 for an equilateral triangle, 0 for a degenerate one.
inline double triangle_quality(const vec3& a, const vec3& b, const vec3& c) {
  const double edges = squared_norm(b - a) + squared_norm(c - b) + squared_norm(a - c);
  if (!(edges > 0)) return 0;
  return 2 * std::sqrt(3.0) * norm(area_vector(a, b, c)) / edges;
}

/// Shortest over longest edge (the quality report's "edge ratio").
inline double edge_ratio(const vec3& a, const vec3& b, const vec3& c) {
  const double ab = distance(a, b), bc = distance(b, c), ca = distance(c, a);
  const double longest = std::fmax(ab, std::fmax(bc, ca));
  return longest > 0 ? std::fmin(ab, std::fmin(bc, ca)) / longest : 0;
}

/// Outward unit normal of the surface at p: −∇φ/|∇φ| (zero where ∇φ = 0).
inline vec3 field_normal(const gaussian_field& field, const vec3& p) {
  vec3 gradient;
  field.value_and_gradient(p, gradient);
  return normalized(-gradient);
}

/// One Newton step along ∇φ from p, and the field normal at p: the relaxation's cheap projection (one field
/// evaluation), exact to second order in the distance to the surface; project_onto_surface settles the vertices
/// afterwards. Returns false, leaving both unchanged, when ∇φ vanishes or the step exceeds max_move Å.
inline bool newton_step_to_surface(const gaussian_field& field, vec3& p, vec3& normal, double max_move) {
  vec3 gradient;
  const double residual = field.value_and_gradient(p, gradient) - field.t0();
  const double g2 = squared_norm(gradient);
  if (!(g2 > 0)) return false;
  const vec3 step = gradient * (residual / g2);
  if (squared_norm(step) > max_move * max_move) return false;
  p -= step;
  normal = -gradient / std::sqrt(g2);
  return true;
}

/// Newton steps along ∇φ (as gaussian_field::project_to_surface) until the first-order distance |φ − t0| / |∇φ| is
/// at most `tolerance` Å. Stopping on that distance rather than on 1e-9·t0, and taking the normal from the last
/// evaluation, saves about half of the field evaluations of the remesher, its main cost. Returns false, leaving p
/// and normal unchanged, when ∇φ vanishes, it does not converge, or it would move more than max_move Å. Adds the
/// field evaluations made to `*evaluations` when given.
inline bool project_onto_surface(const gaussian_field& field, vec3& p, vec3& normal, double max_move,
                                 double tolerance, std::size_t* evaluations = nullptr) {
  constexpr int max_steps = 16;
  vec3 q = p;
  for (int step = 0; step < max_steps; ++step) {
    if (evaluations) ++*evaluations;
    vec3 gradient;
    const double residual = field.value_and_gradient(q, gradient) - field.t0();
    const double g2 = squared_norm(gradient);
    if (!(g2 > 0)) return false;
    if (std::abs(residual) <= tolerance * std::sqrt(g2)) {
      p = q;
      normal = -gradient / std::sqrt(g2);
      return true;
    }
    vec3 move = gradient * (residual / g2);
    const double length = norm(move);
    if (length > 0.5 * max_move) move *= 0.5 * max_move / length;  // damped far from the surface
    q -= move;
    if (squared_norm(q - p) > max_move * max_move) return false;
  }
  return false;
}

}  // namespace tracemesh::detail
