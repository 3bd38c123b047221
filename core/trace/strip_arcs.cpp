#include "core/trace/strip_arcs.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/analysis/triangle_intersection.hpp"

namespace tracemesh {
namespace {

/// Passes over a strip whose arcs conflict (an arc failed or ended on a root already taken): each divides the step
/// by 4 and limits the normal's turn per step to 10°.
constexpr int max_trace_attempts = 3;
constexpr double retry_step_divisor = 4;
constexpr double retry_cos_bound = 0.984807753012208;  // cos 10°
/// Levels t0·(1 + shift) tried, in order, for a strip whose passes above all failed: where a wall is tangent to the
/// surface at a saddle (or a pinch between two sharp atoms), the contour at t0 crosses itself there (an X) and no
/// walk gets past; at a level just above or below, it splits into two branches that do not meet. Found on `mache`
/// at d = −15 (README, "Deviations from the paper").
constexpr std::array<double, 4> level_shifts{1e-3, -1e-3, 1e-2, -1e-2};
/// A root moved to a shifted level must stay within this × the gap to its neighbours on the line.
constexpr double max_shifted_root_move = 0.25;
/// An arc's crossing is matched to a root of the right φ_x sign within this × h̃ of it.
constexpr double end_match_fraction = 0.25;
/// Extreme points closer than this × the resampling spacing (along the arc) to another kept point are not kept.
constexpr double min_extreme_gap = 0.1;
/// Extreme points closer than this × h̃ to a line of their strip are not kept. Where the surface's silhouette in x
/// passes near a line, each of the two planes through that line has an extreme point next to it, and the two were
/// joined by an edge all but degenerate: such pairs made 49 of the 65 raw triangles with an edge ratio below 0.2 on
/// fas2 at 1 v/Å² (README "Deviations"). The arc still keeps points about h̃ apart.
constexpr double extreme_line_clearance = 0.2;
/// The first step from a root is at most this × the distance to the next root of its line, so that a walk from one
/// root of a near-tangency cannot step over the other.
constexpr double first_step_fraction = 0.5;

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

/// The lines v = low and v = high of a strip, in the plane's in-plane axis v.
struct strip_lines {
  int v_axis = 1;
  double low = 0, high = 0;
  double distance_to_nearest(const vec3& p) const {
    return std::min(std::abs(p[v_axis] - low), std::abs(p[v_axis] - high));
  }
};

/// A vertex an arc keeps: a walk point or a point interpolated between two, and the walk point nearest to it (kept
/// instead when an interpolated point cannot be polished onto the contour).
struct kept_point {
  surface_sample sample;
  std::uint32_t walk_point = 0;
  double length = 0;  ///< arc length of the point along the walk
};

/// The point at arc length s (cumulative `length`, strictly inside the walk), interpolated between its two walk
/// points (position and gradient linear: within the chord's sagitta of the contour, polished onto it when kept).
kept_point point_at_length(const std::vector<surface_sample>& points, const std::vector<double>& length, double s) {
  const auto after = std::upper_bound(length.begin() + 1, length.end() - 1, s);
  const auto n = static_cast<std::size_t>(after - length.begin()) - 1;
  const double segment = length[n + 1] - length[n];
  const double t = segment > 0 ? std::clamp((s - length[n]) / segment, 0.0, 1.0) : 0.5;
  const surface_sample &a = points[n], &b = points[n + 1];
  return {{a.position + (b.position - a.position) * t, a.gradient + (b.gradient - a.gradient) * t, false},
          static_cast<std::uint32_t>(t < 0.5 ? n : n + 1), s};
}

/// The vertex of an arc whose ends are both on the line v = line_v and which keeps no other: its point farthest from
/// the line. (Where the line cuts a thin cap, this arc and the perpendicular plane's return arc through the same two
/// roots bound a lens and both points sit at its middle; putting them at a third and two thirds of the span instead
/// left a cell of 3j6r_asu at 1 v/Å² that no triangulation could close, README "Deviations".)
kept_point return_arc_point(const std::vector<surface_sample>& points, const std::vector<double>& length, int v_axis,
                            double line_v) {
  std::size_t farthest = 1;
  for (std::size_t n = 1; n + 1 < points.size(); ++n) {
    if (std::abs(points[n].position[v_axis] - line_v) > std::abs(points[farthest].position[v_axis] - line_v)) {
      farthest = n;
    }
  }
  return {points[farthest], static_cast<std::uint32_t>(farthest), length[farthest]};
}

/// The vertices an arc keeps strictly between its ends, in walk order: every extreme point not within
/// extreme_line_clearance of a line, and between consecutive kept points about one point per `spacing` of arc
/// length, at equal arc-length fractions (method.md §7.7), interpolated along the walk. An arc whose ends are on the
/// line v = line_v and which keeps nothing else keeps return_arc_point().
std::vector<kept_point> resample(const std::vector<surface_sample>& points, const std::vector<double>& length,
                                 double spacing, bool same_line, const strip_lines& lines, double line_v) {
  const int v_axis = lines.v_axis;
  const double h = lines.high - lines.low;
  const double clearance = extreme_line_clearance * h;
  const std::size_t last = points.size() - 1;
  std::vector<std::uint32_t> forced{0};
  const auto phi_x = [&](std::size_t n) {  // |φ_x| / |g| in the plane
    const vec3& g = points[n].gradient;
    return std::abs(g.x) / std::sqrt(g.x * g.x + g[v_axis] * g[v_axis]);
  };
  // One extreme point per run of consecutive ones (near a tangency every walk point qualifies), the flattest, and
  // none closer than min_extreme_gap × spacing to a kept end: a shorter edge would be all but degenerate.
  const double min_gap = min_extreme_gap * spacing;
  for (std::size_t n = 1; n < last; ++n) {
    if (!points[n].extreme) continue;
    std::size_t best = n;
    for (; n + 1 < last && points[n + 1].extreme; ++n) {
      if (phi_x(n + 1) < phi_x(best)) best = n + 1;
    }
    const bool near_start = length[best] - length[forced.back()] < min_gap;
    const bool near_end = length[last] - length[best] < min_gap;
    const bool near_line = lines.distance_to_nearest(points[best].position) < clearance;
    if (!near_start && !near_end && !near_line) forced.push_back(static_cast<std::uint32_t>(best));
  }
  forced.push_back(static_cast<std::uint32_t>(last));
  std::vector<kept_point> kept;
  for (std::size_t f = 0; f + 1 < forced.size(); ++f) {
    const std::uint32_t a = forced[f], b = forced[f + 1];
    if (f > 0) kept.push_back({points[a], a, length[a]});
    const double span = length[b] - length[a];
    const auto pieces = static_cast<long>(std::max(1.0, std::round(span / spacing)));
    for (long q = 1; q < pieces; ++q) {
      const double target = length[a] + span * static_cast<double>(q) / static_cast<double>(pieces);
      kept.push_back(point_at_length(points, length, target));
    }
  }
  if (same_line && kept.empty() && points.size() > 2) kept.push_back(return_arc_point(points, length, v_axis, line_v));
  return kept;
}

/// The sign φ_x must have at the end of an arc traced with `sign` that leaves the strip through line `end_side`
/// (s·φ_x > 0 through the high line, < 0 through the low one).
int end_sign(int end_side, int sign) { return end_side == 1 ? sign : -sign; }

/// The root at which an arc ending at `x` arrives: the nearest root whose φ_x has `phi_x_sign`, within `reach` Å;
/// -1 when there is none. Two roots of a near-tangency can be closer than the crossing's accuracy;
/// their opposite signs of φ_x tell them apart.
std::int64_t end_root(std::span<const line_point> roots, double x, int phi_x_sign, double reach) {
  std::int64_t best = -1;
  double best_distance = reach;
  const auto first = std::lower_bound(roots.begin(), roots.end(), x - reach,
                                      [](const line_point& p, double value) { return p.x < value; });
  for (auto it = first; it != roots.end() && it->x <= x + reach; ++it) {
    const double d = std::abs(it->x - x);
    if (it->gradient.x * phi_x_sign > 0 && d < best_distance) {
      best_distance = d;
      best = it - roots.begin();
    }
  }
  return best;
}

/// An arc traced but not yet stored: its walk, the points it keeps (polished, in walk order) and its ends.
struct pending_arc {
  std::vector<surface_sample> walk;
  std::vector<double> length;  ///< arc length along the walk
  std::vector<kept_point> kept;
  vec3 first, last;            ///< the roots it starts (walk order) and ends at
  bool canonical = true;
  strip_arc stored;
};

/// Polished points take a Newton update shorter than this (Å) without evaluating the field after it: the point is
/// then within ~curvature × 1e-12 Å of the contour, and its gradient, from before the update, is off by ~1e-6 of
/// its length. Newton converges quadratically, so this saves the evaluation that would only confirm convergence.
constexpr double polish_blind_step = 1e-6;

/// Puts a point near the contour onto it to 1e-11 Å, keeping its flags; false (p unchanged) when that fails. Through
/// the walk's neighbourhood when the walk is on the exact field (its atoms are gathered already), on `field` directly
/// otherwise (an arc polishes too few points to repay a gather of its own).
bool polish(const gaussian_field& field, field_neighbourhood& walk, const trace_plane& plane, surface_sample& p,
            double h, std::size_t& evaluations) {
  constexpr double tolerance = 1e-11;
  surface_sample polished;
  const bool corrected =
      &walk.field() == &field
          ? correct_in_plane(walk, plane, p.position, h, polished, evaluations, tolerance, polish_blind_step)
          : correct_in_plane(field, plane, p.position, h, polished, evaluations, tolerance, polish_blind_step);
  if (!corrected) return false;
  polished.extreme = p.extreme;
  p = polished;
  return true;
}

/// Rounds of untangle_arcs (a round splits every crossing edge; one or two rounds untangle the hairpins found).
constexpr int max_untangle_rounds = 8;

/// One edge of an arc's polyline in its strip's plane (x and the in-plane axis across the strip).
struct polyline_edge {
  detail::point2 from, to;
  std::uint32_t arc, index;  ///< joins vertex `index` and `index + 1` of arc `arc` (vertex 0: its first root)
  double low_x() const { return std::min(from.x, to.x); }
};

/// Vertex n of an arc's polyline: its first root, its kept points, its last root.
const vec3& polyline_vertex(const pending_arc& arc, std::size_t n) {
  return n == 0 ? arc.first : n == arc.kept.size() + 1 ? arc.last : arc.kept[n - 1].sample.position;
}

/// The polylines' edges, arc after arc.
std::vector<polyline_edge> polyline_edges(const std::vector<pending_arc>& arcs, int v_axis) {
  std::vector<polyline_edge> out;
  for (std::uint32_t a = 0; a < arcs.size(); ++a) {
    for (std::uint32_t n = 0; n <= arcs[a].kept.size(); ++n) {
      const vec3 &p = polyline_vertex(arcs[a], n), &q = polyline_vertex(arcs[a], n + 1);
      out.push_back({{p.x, p[v_axis]}, {q.x, q[v_axis]}, a, n});
    }
  }
  return out;
}

/// Edges that meet another edge other than their neighbour on the same arc (exactly: touching counts), as
/// (arc, index), sorted. Edges are swept in x: only those whose x ranges overlap are tested.
std::vector<std::pair<std::uint32_t, std::uint32_t>> crossing_edges(std::vector<polyline_edge> edges) {
  std::sort(edges.begin(), edges.end(),
            [](const polyline_edge& a, const polyline_edge& b) { return a.low_x() < b.low_x(); });
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const polyline_edge& a = edges[i];
    const double a_high_x = std::max(a.from.x, a.to.x);
    for (std::size_t j = i + 1; j < edges.size() && edges[j].low_x() <= a_high_x; ++j) {
      const polyline_edge& b = edges[j];
      if (a.arc == b.arc && (a.index + 1 == b.index || b.index + 1 == a.index)) continue;
      if (!detail::segments_intersect_2d(a.from, a.to, b.from, b.to)) continue;
      out.emplace_back(a.arc, a.index);
      out.emplace_back(b.arc, b.index);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// Keeps the walk point between vertices `index` and `index + 1` of `arc` that lies farthest from their chord
/// (polished onto the contour); false when the walk has no point between them.
bool split_edge(const gaussian_field& field, field_neighbourhood& walk, const trace_plane& plane, double h,
                pending_arc& arc, std::uint32_t index, strip_trace& out) {
  const int v = plane.v_axis();
  const double s0 = index == 0 ? 0.0 : arc.kept[index - 1].length;
  const double s1 = index == arc.kept.size() ? arc.length.back() : arc.kept[index].length;
  const vec3 &p = polyline_vertex(arc, index), &q = polyline_vertex(arc, index + 1);
  const auto offset = [&](const vec3& w) {  // ∝ the distance from w to the chord pq in the plane
    return std::abs((q.x - p.x) * (w[v] - p[v]) - (q[v] - p[v]) * (w.x - p.x));
  };
  std::size_t best = 0;
  for (std::size_t n = 1; n + 1 < arc.walk.size(); ++n) {
    if (!(arc.length[n] > s0 && arc.length[n] < s1)) continue;
    if (best == 0 || offset(arc.walk[n].position) > offset(arc.walk[best].position)) best = n;
  }
  if (best == 0) return false;
  kept_point k{arc.walk[best], static_cast<std::uint32_t>(best), arc.length[best]};
  if (!polish(field, walk, plane, k.sample, h, out.evaluations)) ++out.unpolished;
  arc.kept.insert(arc.kept.begin() + index, k);
  ++out.untangled_points;
  return true;
}

/// The arcs of one strip as kept (straight edges between their kept points) must not cross each other or
/// themselves, as the contour does not: where the contour makes a hairpin narrower than a chord's sagitta (a pinch
/// between sharp atoms), the straight edges of its two sides cross, and no cell beside the strip can close its loop.
/// Each crossing edge keeps its walk point farthest from its chord, until none crosses (Douglas–Peucker, driven by
/// crossings).
void untangle_arcs(const gaussian_field& field, field_neighbourhood& walk, const trace_plane& plane, double h,
                   std::vector<pending_arc>& arcs, strip_trace& out) {
  for (int round = 0; round < max_untangle_rounds; ++round) {
    const auto crossing = crossing_edges(polyline_edges(arcs, plane.v_axis()));
    if (crossing.empty()) return;
    bool split = false;
    // From the last edge of each arc back, so that an insertion does not renumber the edges still to split.
    for (auto it = crossing.rbegin(); it != crossing.rend(); ++it) {
      split |= split_edge(field, walk, plane, h, arcs[it->first], it->second, out);
    }
    if (!split) return;
  }
}

/// Distance from root i to the nearest other root of its line (infinity when alone).
double gap_to_neighbour(std::span<const line_point> roots, std::size_t i) {
  double gap = std::numeric_limits<double>::infinity();
  if (i > 0) gap = roots[i].x - roots[i - 1].x;
  if (i + 1 < roots.size()) gap = std::min(gap, roots[i + 1].x - roots[i].x);
  return gap;
}

/// One pass over the strip's roots with the given step: every root not yet the end of an arc starts one. An arc is
/// refused when it fails, ends on a root that already has its arc, or comes back to its own line without an interior
/// point; its root may still be reached by the arc of another root (the walk from the other end of the same piece of
/// contour: from one end it may die where the contour turns within a hair, and succeed from the other). Roots that
/// end the pass without an arc are the failures.
/// `roots` are the strip's low and high lines' roots at the level traced, t0 + level_shift; the kept points are
/// polished onto φ = t0 whatever the level.
strip_trace trace_strip_once(const gaussian_field& field, const std::array<std::span<const line_point>, 2>& roots,
                             const strip_id& strip, const strip_settings& settings, double level_shift = 0) {
  strip_trace out;
  const double h = settings.spacing;
  const trace_plane surface_plane = plane_of(strip, h);
  trace_plane plane = surface_plane;
  plane.level_shift = level_shift;
  const int v = plane.v_axis();
  std::vector<char> covered[2] = {std::vector<char>(roots[0].size(), 0), std::vector<char>(roots[1].size(), 0)};
  trace_step_settings step;
  step.low_roots = roots[0];
  step.high_roots = roots[1];
  step.v_low = low_v(strip, h);
  step.v_high = step.v_low + h;
  step.max_step = settings.max_step;
  step.cos_bound = settings.cos_bound;
  step.extreme_tolerance = settings.extreme_tolerance;
  step.walk_field = settings.walk_field;
  // One neighbourhood of the walk's field for the whole pass: the arcs of a strip lie close together.
  field_neighbourhood walk(settings.walk_field != nullptr ? *settings.walk_field : field,
                           trace_neighbourhood_reach(plane, settings.max_step));

  std::vector<pending_arc> pending;
  for (int side = 0; side < 2; ++side) {
    for (std::size_t i = 0; i < roots[side].size(); ++i) {
      if (covered[side][i]) continue;
      const line_point& root = roots[side][i];
      const surface_sample start{root_position(strip, side, root.x, h), root.gradient, false};
      // Into the strip: the tangent's v component s·φ_x must be > 0 from the low line, < 0 from the high one.
      const int sign = (side == 0 ? 1 : -1) * (root.gradient.x > 0 ? 1 : -1);
      step.first_step = std::min(settings.max_step, first_step_fraction * gap_to_neighbour(roots[side], i));
      traced_arc arc = trace_contour(field, walk, plane, start, sign, step, out.evaluations);
      if (arc.end == trace_end::failed) continue;
      const int end_side = arc.end == trace_end::low_line ? 0 : 1;
      // The end must be a root whose φ_x lets the walk leave the strip there (end_root takes no other): else it
      // jumped to another branch of the contour and the arcs' directions would not chain (§7.10). The line roots
      // are complete (line_roots.hpp), so a crossing with no such root near it went astray too.
      const std::int64_t match = end_root(roots[end_side], arc.points.back().position.x, end_sign(end_side, sign),
                                          settings.spacing * end_match_fraction);
      if (match < 0) continue;
      const bool taken = covered[end_side][static_cast<std::size_t>(match)] ||
                         (end_side == side && match == static_cast<std::int64_t>(i));
      const bool bare_return = end_side == side && arc.points.size() < 3;  // needs an interior point (§7.7)
      if (taken || bare_return) continue;
      covered[side][i] = 1;
      covered[end_side][match] = 1;
      const double end_x = roots[end_side][match].x;
      const double line_v = side == 0 ? step.v_low : step.v_high;
      pending_arc p;
      p.length = arc_lengths(arc.points);
      p.kept = resample(arc.points, p.length, settings.resample_spacing, end_side == side,
                        strip_lines{v, step.v_low, step.v_high}, line_v);
      for (kept_point& k : p.kept) {
        // An interpolated point that cannot be polished gives way to its walk point (within the corrector's tolerance).
        if (!polish(field, walk, surface_plane, k.sample, h, out.evaluations)) {
          k.sample = arc.points[k.walk_point];
          if (!polish(field, walk, surface_plane, k.sample, h, out.evaluations)) ++out.unpolished;
        }
      }
      const arc_end from{side, root.x}, to{end_side, end_x};
      p.canonical = sign > 0;
      p.stored.start = p.canonical ? from : to;
      p.stored.end = p.canonical ? to : from;
      p.first = start.position;
      p.last = root_position(strip, end_side, end_x, h);
      p.walk = std::move(arc.points);
      pending.push_back(std::move(p));
    }
  }
  untangle_arcs(field, walk, surface_plane, h, pending, out);
  for (pending_arc& p : pending) {
    p.stored.first_interior = static_cast<std::uint32_t>(out.interior.size());
    p.stored.interior_count = static_cast<std::uint32_t>(p.kept.size());
    for (std::size_t n = 0; n < p.kept.size(); ++n) {
      const surface_sample& q = p.kept[p.canonical ? n : p.kept.size() - 1 - n].sample;
      out.interior.push_back(q);
      if (q.extreme) ++out.extreme_points;
    }
    out.arcs.push_back(p.stored);
  }
  for (int side = 0; side < 2; ++side) {
    out.failures += static_cast<std::size_t>(std::count(covered[side].begin(), covered[side].end(), 0));
  }
  return out;
}

/// The roots of one side of `strip` moved along their line to the level t0 + level_shift (Newton in x from each);
/// false when one has no counterpart there: Newton fails, moves it more than max_shifted_root_move × the gap to a
/// neighbour, or its φ_x changes sign (the two roots of a near-tangency that merge at that level).
bool shifted_roots(const gaussian_field& field, const strip_id& strip, int side, std::span<const line_point> roots,
                   double level_shift, double h, std::vector<line_point>& out, std::size_t& evaluations) {
  out.clear();
  for (std::size_t i = 0; i < roots.size(); ++i) {
    const double reach = std::min(h, max_shifted_root_move * gap_to_neighbour(roots, i));
    surface_sample moved;
    if (!polish_on_line(field, root_position(strip, side, roots[i].x, h), reach, moved, evaluations, level_shift) ||
        moved.gradient.x * roots[i].gradient.x <= 0) {
      return false;
    }
    out.push_back({moved.position.x, moved.gradient});
  }
  return true;
}

/// The strip traced at a level shifted by level_shifts[n]·t0 (see there), its arcs ending on the true roots; false
/// when that level gives no complete set of arcs either (a root without counterpart or a failure).
bool trace_strip_shifted(const gaussian_field& field, const std::array<std::span<const line_point>, 2>& roots,
                         const strip_id& strip, const strip_settings& settings, double relative_shift,
                         strip_trace& out) {
  const double level_shift = relative_shift * field.t0();
  std::array<std::vector<line_point>, 2> moved;
  std::size_t evaluations = 0;
  for (int side = 0; side < 2; ++side) {
    if (!shifted_roots(field, strip, side, roots[side], level_shift, settings.spacing, moved[side], evaluations)) {
      out.evaluations += evaluations;
      return false;
    }
  }
  strip_trace shifted = trace_strip_once(field, {moved[0], moved[1]}, strip, settings, level_shift);
  out.evaluations += evaluations + shifted.evaluations;
  // Every kept point must be back on φ = t0: the walk's own points lie on the shifted level.
  if (shifted.failures > 0 || shifted.unpolished > 0) return false;
  // Each arc end is a moved root; it ends on the root it was moved from.
  const auto original_x = [&](const arc_end& end) {
    const std::vector<line_point>& m = moved[end.side];
    const auto it = std::lower_bound(m.begin(), m.end(), end.x, [](const line_point& p, double x) { return p.x < x; });
    return roots[end.side][static_cast<std::size_t>(it - m.begin())].x;
  };
  for (strip_arc& arc : shifted.arcs) {
    arc.start.x = original_x(arc.start);
    arc.end.x = original_x(arc.end);
  }
  shifted.evaluations = out.evaluations;
  shifted.retraced = out.retraced + out.arcs.size() + out.failures;
  shifted.level_shifted = true;
  out = std::move(shifted);
  return true;
}

}  // namespace

std::vector<strip_id> strips_beside(const trace_lines& lines) {
  std::vector<strip_id> strips;
  strips.reserve(4 * lines.line_count());
  for (std::size_t n = 0; n < lines.line_count(); ++n) {
    const line_id& l = lines.id(n);
    strips.push_back({0, l.j - 1, l.k});
    strips.push_back({0, l.j, l.k});
    strips.push_back({1, l.j, l.k - 1});
    strips.push_back({1, l.j, l.k});
  }
  std::sort(strips.begin(), strips.end());
  strips.erase(std::unique(strips.begin(), strips.end()), strips.end());
  return strips;
}

strip_trace trace_strip(const gaussian_field& field, const trace_lines& lines, const strip_id& strip,
                        const strip_settings& settings) {
  const std::array<std::span<const line_point>, 2> roots{lines.roots_of(strip.low_line()),
                                                         lines.roots_of(strip.high_line())};
  strip_settings attempt_settings = settings;
  std::size_t evaluations = 0, retraced = 0;
  for (int attempt = 0;; ++attempt) {
    strip_trace out = trace_strip_once(field, roots, strip, attempt_settings);
    evaluations += out.evaluations;
    if (out.failures == 0 || attempt + 1 == max_trace_attempts) {
      out.evaluations = evaluations;
      out.retraced = retraced;
      if (out.failures > 0) {
        // The walks die at a point where the contour crosses itself: trace it just off t0 instead, on the exact
        // field with the first pass's steps.
        strip_settings shifted_settings = settings;
        shifted_settings.walk_field = nullptr;
        for (const double shift : level_shifts) {
          if (trace_strip_shifted(field, roots, strip, shifted_settings, shift, out)) break;
        }
      }
      return out;
    }
    // A conflict means some arc jumped to another branch of the contour (near a saddle of φ in the plane): trace
    // the whole strip again on the exact field with shorter steps and a tighter turn limit, so that the earlier
    // arcs are redone too.
    retraced += out.arcs.size() + out.failures;
    attempt_settings.walk_field = nullptr;  // the approximate field's jumps at its cutoff may be the cause
    attempt_settings.max_step /= retry_step_divisor;
    attempt_settings.cos_bound = std::max(attempt_settings.cos_bound, retry_cos_bound);
  }
}

}  // namespace tracemesh
