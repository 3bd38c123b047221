#include "core/edge_root.hpp"

#include <algorithm>
#include <cmath>

namespace tracemesh {

vec3 solve_edge_root(const gaussian_field& field, const vec3& a, const vec3& b, bool a_inside) {
  const vec3 direction = b - a;
  const double t0 = field.t0();
  // f(t) = φ(a + t·direction) − t0, with f ≥ 0 on the inside end. Keep lo on the inside, hi on the outside.
  double inside_t = a_inside ? 0.0 : 1.0;
  double outside_t = a_inside ? 1.0 : 0.0;
  double t = 0.5;
  for (int iteration = 0; iteration < 100; ++iteration) {
    vec3 gradient;
    const double f = field.value_and_gradient(a + direction * t, gradient) - t0;
    if (f == 0) break;
    (f > 0 ? inside_t : outside_t) = t;
    if (std::abs(outside_t - inside_t) < 1e-12) break;
    const double slope = dot(gradient, direction);
    double next = slope != 0 ? t - f / slope : 0.5 * (inside_t + outside_t);
    const double lo = std::min(inside_t, outside_t), hi = std::max(inside_t, outside_t);
    if (!(next > lo && next < hi)) next = 0.5 * (inside_t + outside_t);  // Newton left the bracket: bisect
    if (std::abs(next - t) < 1e-13) {
      t = next;
      break;
    }
    t = next;
  }
  t = std::clamp(t, edge_root_margin, 1 - edge_root_margin);
  return a + direction * t;
}

}  // namespace tracemesh
