#include "core/trace/strip_arcs.hpp"

#include <algorithm>
#include <cmath>

namespace tracemesh {
namespace {

/// Retries of an arc that failed or ended on a root already taken: each divides the step by 4 and limits the
/// normal's turn per step to 10°.
constexpr int max_trace_attempts = 3;
constexpr double retry_step_divisor = 4;
constexpr double retry_cos_bound = 0.984807753012208;  // cos 10°

trace_plane plane_of(const strip_id& strip, double h) {
  return strip.orientation == 0 ? trace_plane{2, static_cast<double>(strip.k) * h}
                                : trace_plane{1, static_cast<double>(strip.j) * h};
}

double low_v(const strip_id& strip, double h) {
  return static_cast<double>(strip.orientation == 0 ? strip.j : strip.k) * h;
}

vec3 root_position(const strip_id& strip, int side, double x, double h) {
  const double j = static_cast<double>(strip.j), k = static_cast<double>(strip.k);
  return strip.orientation == 0 ? vec3{x, (j + side) * h, k * h} : vec3{x, j * h, (k + side) * h};
}

/// Cumulative arc length along the traced points.
std::vector<double> arc_lengths(const std::vector<surface_sample>& points) {
  std::vector<double> length(points.size(), 0.0);
  for (std::size_t n = 1; n < points.size(); ++n) {
    length[n] = length[n - 1] + distance(points[n - 1].position, points[n].position);
  }
  return length;
}

/// Indices (strictly between the ends, increasing) of the traced points kept as vertices: every extreme point, and
/// between consecutive kept points about one point per `spacing` of arc length, at equal arc-length fractions
/// (method.md §7.7). An arc whose ends are on one line keeps at least its point farthest from that line.
std::vector<std::uint32_t> resample(const std::vector<surface_sample>& points, double spacing, bool same_line,
                                    int v_axis, double line_v) {
  const std::vector<double> length = arc_lengths(points);
  const std::size_t last = points.size() - 1;
  std::vector<std::uint32_t> forced{0};
  for (std::size_t n = 1; n < last; ++n) {
    if (points[n].extreme) forced.push_back(static_cast<std::uint32_t>(n));
  }
  forced.push_back(static_cast<std::uint32_t>(last));
  std::vector<std::uint32_t> kept;
  for (std::size_t f = 0; f + 1 < forced.size(); ++f) {
    const std::uint32_t a = forced[f], b = forced[f + 1];
    if (f > 0) kept.push_back(a);
    const double span = length[b] - length[a];
    const auto pieces = static_cast<long>(std::max(1.0, std::round(span / spacing)));
    std::uint32_t next = a + 1;
    for (long q = 1; q < pieces; ++q) {
      const double target = length[a] + span * static_cast<double>(q) / static_cast<double>(pieces);
      while (next + 1 < b && length[next + 1] <= target) ++next;
      std::uint32_t pick = next;
      if (next + 1 < b && length[next + 1] - target < target - length[next]) pick = next + 1;
      if (pick >= b || (!kept.empty() && pick <= kept.back()) || pick <= a) continue;
      kept.push_back(pick);
      next = pick + 1;
    }
  }
  if (same_line && kept.empty() && points.size() > 2) {
    std::uint32_t farthest = 1;
    for (std::uint32_t n = 1; n < last; ++n) {
      if (std::abs(points[n].position[v_axis] - line_v) > std::abs(points[farthest].position[v_axis] - line_v)) {
        farthest = n;
      }
    }
    kept.push_back(farthest);
  }
  return kept;
}

}  // namespace

strip_trace trace_strip(const gaussian_field& field, const trace_lines& lines, const strip_id& strip,
                        const strip_settings& settings) {
  strip_trace out;
  const double h = settings.spacing;
  const trace_plane plane = plane_of(strip, h);
  const int v = plane.v_axis();
  const std::span<const line_point> roots[2] = {lines.roots_of(strip.low_line()), lines.roots_of(strip.high_line())};
  const line_id line_ids[2] = {strip.low_line(), strip.high_line()};
  std::vector<char> covered[2] = {std::vector<char>(roots[0].size(), 0), std::vector<char>(roots[1].size(), 0)};
  trace_step_settings step;
  step.v_low = low_v(strip, h);
  step.v_high = step.v_low + h;
  step.extreme_tolerance = settings.extreme_tolerance;

  for (int side = 0; side < 2; ++side) {
    for (std::size_t i = 0; i < roots[side].size(); ++i) {
      if (covered[side][i]) continue;
      const line_point& root = roots[side][i];
      const surface_sample start{root_position(strip, side, root.x, h), root.gradient, false};
      // Into the strip: the tangent's v component s·φ_x must be > 0 from the low line, < 0 from the high one.
      const int sign = (side == 0 ? 1 : -1) * (root.gradient.x > 0 ? 1 : -1);
      traced_arc arc;
      int end_side = 0;
      std::int64_t match = -1;
      bool accepted = false;
      for (int attempt = 0; attempt < max_trace_attempts && !accepted; ++attempt) {
        step.max_step = settings.max_step / std::pow(retry_step_divisor, attempt);
        step.cos_bound = attempt == 0 ? settings.cos_bound : std::max(settings.cos_bound, retry_cos_bound);
        arc = trace_contour(field, plane, start, sign, step, out.evaluations);
        if (attempt > 0) ++out.retraced;
        if (arc.end == trace_end::failed) continue;
        end_side = arc.end == trace_end::low_line ? 0 : 1;
        match = lines.match(roots[end_side], arc.points.back().position.x);
        const bool taken = match >= 0 && (covered[end_side][match] || (end_side == side && match == static_cast<std::int64_t>(i)));
        const bool bare_return = end_side == side && arc.points.size() < 3;  // needs an interior point (§7.7)
        accepted = !taken && !bare_return;
      }
      covered[side][i] = 1;
      if (!accepted) {
        ++out.failures;
        continue;
      }
      double end_x = arc.points.back().position.x;
      if (match >= 0) {
        covered[end_side][match] = 1;
        end_x = roots[end_side][match].x;
      } else {
        out.late_roots.push_back({line_ids[end_side], {end_x, arc.points.back().gradient, true}});
      }
      const std::vector<std::uint32_t> kept =
          resample(arc.points, settings.resample_spacing, end_side == side, v, side == 0 ? step.v_low : step.v_high);
      strip_arc stored;
      stored.first_interior = static_cast<std::uint32_t>(out.interior.size());
      stored.interior_count = static_cast<std::uint32_t>(kept.size());
      const arc_end from{side, root.x}, to{end_side, end_x};
      const bool canonical = sign > 0;
      stored.start = canonical ? from : to;
      stored.end = canonical ? to : from;
      for (std::size_t n = 0; n < kept.size(); ++n) {
        const surface_sample& p = arc.points[kept[canonical ? n : kept.size() - 1 - n]];
        out.interior.push_back(p);
        if (p.extreme) ++out.extreme_points;
      }
      out.arcs.push_back(stored);
    }
  }
  return out;
}

}  // namespace tracemesh
