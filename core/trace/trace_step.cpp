#include "core/trace/trace_step.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

namespace tracemesh {
namespace {

/// A corrector or polisher stops when |φ − t0| ≤ this × t0 or |φ − t0| / |g| ≤ converged_distance.
constexpr double converged_residual = 1e-12;
constexpr double converged_distance = 1e-11;  // Å
constexpr int max_newton_iterations = 30;
/// A crossing interpolated from a step of length h takes a known root of its line within this × h of it as its
/// end (when no other root is within twice that).
constexpr double known_root_reach = 0.2;

bool converged(double residual, double gradient_norm, double t0, double distance = converged_distance) {
  return std::abs(residual) <= converged_residual * t0 || std::abs(residual) <= distance * gradient_norm;
}

/// The in-plane components (φ_x, φ_v) of a gradient.
struct planar {
  double x, v;
  double norm() const { return std::sqrt(x * x + v * v); }  // not std::hypot: slow, and no overflow to fear here
};
planar in_plane(const vec3& gradient, int v_axis) { return {gradient.x, gradient[v_axis]}; }

/// Unit tangent s·(−φ_v, φ_x) / |g| in (x, v).
planar unit_tangent(const vec3& gradient, int v_axis, int sign) {
  const planar g = in_plane(gradient, v_axis);
  const double n = g.norm();
  return {-sign * g.v / n, sign * g.x / n};
}

/// φ_x / |g|: the x-component of the unit in-plane normal (0 where the contour runs along x).
double relative_phi_x(const vec3& gradient, int v_axis) {
  const planar g = in_plane(gradient, v_axis);
  return g.x / g.norm();
}

/// True when a root of a line lies under the step a → b (its x between theirs) while the step passes closer to
/// that line than its own length: the contour may touch the line there between the two points (a near-tangency,
/// whose two roots can be far closer together than a step), and the walk must not step over it. Roots strictly
/// under the walk would need an arc of their own crossing the walk, so the guard only asks for steps shorter than
/// the walk's distance to the line; the start root is not a reason.
bool skips_a_root(const trace_step_settings& settings, const vec3& a, const vec3& b, int v, double h,
                  const surface_sample& start, bool starts_low) {
  const double lo = std::min(a.x, b.x), hi = std::max(a.x, b.x);
  for (int side = 0; side < 2; ++side) {
    const double line_v = side == 0 ? settings.v_low : settings.v_high;
    if (std::min(std::abs(a[v] - line_v), std::abs(b[v] - line_v)) >= h) continue;
    const std::span<const line_point> roots = side == 0 ? settings.low_roots : settings.high_roots;
    const bool start_line = (side == 0) == starts_low;
    const auto first = std::upper_bound(roots.begin(), roots.end(), lo,
                                        [](double value, const line_point& p) { return value < p.x; });
    for (auto it = first; it != roots.end() && it->x < hi; ++it) {
      if (!(start_line && std::abs(it->x - start.position.x) < 1e-9)) return true;
    }
  }
  return false;
}

/// The known root of `roots` that an interpolated crossing at `x` arrives at: the only root within
/// 2 × known_root_reach; none when there is none, or more than one (a near-tangency, or a root the polynomial
/// missed next to a known one: Newton on the line decides those).
const line_point* known_crossing(std::span<const line_point> roots, double x, double reach) {
  const auto first = std::lower_bound(roots.begin(), roots.end(), x - 2 * reach,
                                      [](const line_point& p, double value) { return p.x < value; });
  if (first == roots.end() || first->x > x + 2 * reach) return nullptr;
  const auto next = first + 1;
  if (next != roots.end() && next->x <= x + 2 * reach) return nullptr;
  return std::abs(first->x - x) <= reach ? &*first : nullptr;
}

/// True when a walk point at v lies within exact_near_line of one of the strip's lines, or beyond it.
bool near_a_line(double v, const trace_step_settings& settings) {
  return v - settings.v_low < settings.exact_near_line || settings.v_high - v < settings.exact_near_line;
}

/// Where the chord p0 → p1 crosses the line it reaches (p1 on or past the line v = line_v): p0 moved along it to
/// v = line_v (step 6).
vec3 chord_crossing(const vec3& p0, const vec3& p1, int v, double line_v) {
  const double f = (line_v - p0[v]) / (p1[v] - p0[v]);
  vec3 guess = p0;
  guess.x += f * (p1.x - p0.x);
  guess[v] = line_v;
  return guess;
}

/// The line a walk point at v has reached (on or past it): v_low or v_high; none while it is inside the strip.
std::optional<double> reached_line(double v, const trace_step_settings& settings) {
  if (v <= settings.v_low) return settings.v_low;
  if (v >= settings.v_high) return settings.v_high;
  return std::nullopt;
}

std::span<const line_point> roots_of_line(double line_v, const trace_step_settings& settings) {
  return line_v == settings.v_low ? settings.low_roots : settings.high_roots;
}

/// The next step's first try: the normal turned by acos(turn) over h, so a step of h·θ_max/θ would turn it by the
/// limit θ_max = acos δ; aim at 80% of that (a rejected step costs a corrector), grow by at most 2× and stay ≤ h₁.
double next_step(double h, double turn, const trace_step_settings& settings) {
  const double angle = std::acos(std::clamp(turn, -1.0, 1.0));
  const double limit = std::acos(settings.cos_bound);
  const double aimed = angle > 0 ? 0.8 * h * limit / angle : 2 * h;
  return std::min({aimed, 2 * h, settings.max_step});
}

double level_of(const gaussian_field& field) { return field.t0(); }
double level_of(const field_neighbourhood& near) { return near.field().t0(); }

}  // namespace

template <class Field>
bool correct_in_plane(Field& field, const trace_plane& plane, vec3 p, double max_move, surface_sample& out,
                      std::size_t& evaluations, double tolerance, double blind_step) {
  const int v = plane.v_axis();
  const double t0 = level_of(field);
  const vec3 origin = p;
  for (int iteration = 0; iteration < max_newton_iterations; ++iteration) {
    vec3 gradient;
    const double residual = field.value_and_gradient(p, gradient) - (t0 + plane.level_shift);
    ++evaluations;
    const planar g = in_plane(gradient, v);
    const double g2 = g.x * g.x + g.v * g.v;
    if (!(g2 > 0)) return false;
    if (converged(residual, std::sqrt(g2), t0, tolerance)) {
      out = {p, gradient, false};
      return true;
    }
    double dx = g.x * residual / g2, dv = g.v * residual / g2;  // Newton along the in-plane gradient (step 3)
    const double length = std::sqrt(dx * dx + dv * dv);
    if (length > 0.5 * max_move) {  // damped far from the contour
      dx *= 0.5 * max_move / length;
      dv *= 0.5 * max_move / length;
    }
    p.x -= dx;
    p[v] -= dv;
    if (distance(p, origin) > max_move) return false;
    if (length < blind_step) {  // the update's own error, ~curvature × length², is far below the walk's needs
      out = {p, gradient, false};
      return true;
    }
  }
  return false;
}

template <class Field>
bool polish_on_line(Field& field, vec3 guess, double max_move, surface_sample& out, std::size_t& evaluations,
                    double level_shift) {
  const double t0 = level_of(field);
  const double x0 = guess.x;
  for (int iteration = 0; iteration < max_newton_iterations; ++iteration) {
    vec3 gradient;
    const double residual = field.value_and_gradient(guess, gradient) - (t0 + level_shift);
    ++evaluations;
    if (converged(residual, std::abs(gradient.x), t0)) {
      out = {guess, gradient, false};
      return true;
    }
    if (gradient.x == 0) return false;
    double dx = residual / gradient.x;
    if (std::abs(dx) > 0.5 * max_move) dx = std::copysign(0.5 * max_move, dx);
    guess.x -= dx;
    if (std::abs(guess.x - x0) > max_move) return false;
  }
  return false;
}

template bool correct_in_plane(const gaussian_field&, const trace_plane&, vec3, double, surface_sample&,
                               std::size_t&, double, double);
template bool correct_in_plane(field_neighbourhood&, const trace_plane&, vec3, double, surface_sample&, std::size_t&,
                               double, double);
template bool polish_on_line(const gaussian_field&, vec3, double, surface_sample&, std::size_t&, double);
template bool polish_on_line(field_neighbourhood&, vec3, double, surface_sample&, std::size_t&, double);

double blind_step_for(double d) {
  constexpr double default_d = -1;
  return trace_step_settings{}.blind_step * std::min(1.0, (1 - 2 * default_d) / (1 - 2 * d));
}

vec3 trace_neighbourhood_reach(const trace_plane& plane, double max_step) {
  vec3 reach{1, 1, 1};
  reach *= neighbourhood_reach_steps * max_step;
  reach[plane.normal_axis] = 0;
  return reach;
}

traced_arc trace_contour(const gaussian_field& field, const trace_plane& plane, const surface_sample& start, int sign,
                         const trace_step_settings& settings, std::size_t& evaluations) {
  field_neighbourhood walk(settings.walk_field != nullptr ? *settings.walk_field : field,
                           trace_neighbourhood_reach(plane, settings.max_step));
  return trace_contour(field, walk, plane, start, sign, settings, evaluations);
}

traced_arc trace_contour(const gaussian_field& field, field_neighbourhood& walk, const trace_plane& plane,
                         const surface_sample& start, int sign, const trace_step_settings& settings,
                         std::size_t& evaluations) {
  const int v = plane.v_axis();
  const double eps = settings.extreme_tolerance;
  const bool starts_low =
      std::abs(start.position[v] - settings.v_low) <= std::abs(start.position[v] - settings.v_high);
  traced_arc arc;
  arc.points.push_back(start);
  surface_sample p0 = start;
  double h = std::min(settings.first_step, settings.max_step);
  // Walking on another field than the exact one, points that land near a line are corrected again on the exact
  // field; walking on the exact field, every evaluation goes through the walk's neighbourhood.
  const bool separate_walk = &walk.field() != &field;
  for (std::size_t steps = 0; steps < settings.max_steps; ++steps) {
    const planar t = unit_tangent(p0.gradient, v, sign);
    const planar g0 = in_plane(p0.gradient, v);
    const double fx0 = relative_phi_x(p0.gradient, v);
    const bool first = steps == 0;
    while (true) {
      if (h < settings.min_step) return arc;  // failed
      vec3 predicted = p0.position;  // step 2: along the tangent
      predicted.x += h * t.x;
      predicted[v] += h * t.v;
      surface_sample p1;
      // Step 3 on the walk field; a point that lands near (or past) a line is corrected again on the exact field,
      // which decides crossings and near-tangencies. Not one past a line whose chord arrives at a lone known root
      // there (below): that root, solved on the exact field, is the crossing, and the walk field's error (~1e-3 Å)
      // is far below the reach that picks it.
      const auto arrives_at_known_root = [&](const surface_sample& q) {
        const std::optional<double> line_v = reached_line(q.position[v], settings);
        return line_v && known_crossing(roots_of_line(*line_v, settings),
                                        chord_crossing(p0.position, q.position, v, *line_v).x,
                                        known_root_reach * h) != nullptr;
      };
      const bool corrected =
          correct_in_plane(walk, plane, predicted, h, p1, evaluations, settings.corrector_tolerance,
                           settings.blind_step) &&
          (!separate_walk || !near_a_line(p1.position[v], settings) || arrives_at_known_root(p1) ||
           correct_in_plane(field, plane, p1.position, h, p1, evaluations, settings.corrector_tolerance,
                            settings.blind_step));
      if (!corrected) {
        h *= 0.5;
        continue;
      }
      const planar g1 = in_plane(p1.gradient, v);
      const double turn = (g0.x * g1.x + g0.v * g1.v) / (g0.norm() * g1.norm());
      const double fx1 = relative_phi_x(p1.gradient, v);
      const bool star1 = turn < settings.cos_bound;                                       // ★1
      const bool star2 = fx0 * fx1 < 0 && std::abs(fx0) > eps && std::abs(fx1) > eps;  // ★2
      const double v1 = p1.position[v];
      const bool back_over_start = first && (starts_low ? v1 <= settings.v_low : v1 >= settings.v_high);
      if (star1 || star2 || back_over_start) {
        h *= 0.5;
        continue;
      }
      p1.extreme = std::abs(fx1) < eps;  // step 4
      if (const std::optional<double> reached = reached_line(v1, settings)) {  // step 6: the segment reaches a line
        const double line_v = *reached;
        const vec3 guess = chord_crossing(p0.position, p1.position, v, line_v);
        surface_sample crossing;
        // The chord's crossing is within ~curvature × h²/8 of the contour's: a lone known root that close is it.
        const line_point* known = known_crossing(roots_of_line(line_v, settings), guess.x, known_root_reach * h);
        if (known != nullptr) crossing = {{known->x, guess.y, guess.z}, known->gradient, false};
        const bool polished =
            known != nullptr ||
            (separate_walk ? polish_on_line(field, guess, h, crossing, evaluations, plane.level_shift)
                           : polish_on_line(walk, guess, h, crossing, evaluations, plane.level_shift));
        // The walk leaves the strip there, so s·φ_x points out through that line; a crossing polished onto the
        // other root of a near-tangency has the opposite sign: localise the crossing with a shorter step. So has the
        // start root itself (the caller's s points the walk into the strip there).
        const double outward = (line_v == settings.v_high ? 1.0 : -1.0) * sign * crossing.gradient.x;
        if (!polished || !(outward > 0)) {
          h *= 0.5;
          continue;
        }
        arc.points.push_back(crossing);
        arc.end = line_v == settings.v_low ? trace_end::low_line : trace_end::high_line;
        return arc;
      }
      if (skips_a_root(settings, p0.position, p1.position, v, h, start, starts_low)) {
        h *= 0.5;
        continue;
      }
      arc.points.push_back(p1);
      p0 = p1;
      h = next_step(h, turn, settings);
      break;
    }
  }
  return arc;
}

}  // namespace tracemesh
