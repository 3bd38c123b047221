// Tests of core/trace/strip_arcs.hpp (Algorithm 1 applied to a whole strip, method.md §7.1, §7.2, §7.7) on one
// atom: with d = −1 and t0 = 1 a lone atom of radius r at the origin has the sphere of radius r as its surface, so
// the line y = J·h̃, z = K·h̃ meets it at x = ±√(r² − y² − z²) (closed form), and every planar contour is a circle.
// r and h̃ are chosen so that no lattice line is tangent to the sphere (y² + z² stays ≥ 0.79 Å² away from r²).
#include "core/trace/strip_arcs.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/io/pqr_reader.hpp"
#include "core/molecule.hpp"
#include "core/trace/trace_parameters.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

constexpr double radius = 1.8;
constexpr double h = 0.7;
constexpr std::int64_t grid = 3;  // lines J, K ∈ [−grid, grid] cover the sphere (3·0.7 > 1.8)

molecule one_atom() {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, radius, 0});
  return mol;
}

/// x of the roots of line (j, k) in closed form (empty when the line misses the sphere).
std::vector<double> exact_roots(std::int64_t j, std::int64_t k, double spacing = h) {
  const double y = static_cast<double>(j) * spacing, z = static_cast<double>(k) * spacing;
  const double rest = radius * radius - y * y - z * z;
  if (rest <= 0) return {};
  const double x = std::sqrt(rest);
  return {-x, x};
}

/// Lines of the grid built from the exact roots, with the field's gradient at each; `skip` (line, x) is left out.
struct skipped_root {
  line_id line;
  double x;
};
trace_lines exact_lines(const gaussian_field& field, std::optional<skipped_root> skip = std::nullopt,
                        double spacing = h) {
  std::vector<trace_lines::entry> entries;
  for (std::int64_t j = -grid; j <= grid; ++j) {
    for (std::int64_t k = -grid; k <= grid; ++k) {
      for (const double x : exact_roots(j, k, spacing)) {
        if (skip && skip->line == line_id{j, k} && std::abs(skip->x - x) < 1e-12) continue;
        line_point p{x, {}};
        field.value_and_gradient({x, static_cast<double>(j) * spacing, static_cast<double>(k) * spacing}, p.gradient);
        entries.push_back({{j, k}, p});
      }
    }
  }
  return trace_lines(std::move(entries));
}

strip_settings settings(double spacing = h) {
  strip_settings s;
  s.spacing = spacing;
  s.max_step = 0.5 * spacing;
  s.resample_spacing = spacing;
  return s;
}

/// The smallest distance between a point of `a` and one of `b`.
double closest_pair(const std::vector<surface_sample>& a, const std::vector<surface_sample>& b) {
  double closest = std::numeric_limits<double>::infinity();
  for (const surface_sample& p : a) {
    for (const surface_sample& q : b) closest = std::min(closest, distance(p.position, q.position));
  }
  return closest;
}

int normal_axis(const strip_id& strip) { return strip.orientation == 0 ? 2 : 1; }
int v_axis(const strip_id& strip) { return strip.orientation == 0 ? 1 : 2; }
double plane_offset(const strip_id& strip) {
  return static_cast<double>(strip.orientation == 0 ? strip.k : strip.j) * h;
}
double line_v(const strip_id& strip, int side) {
  return static_cast<double>((strip.orientation == 0 ? strip.j : strip.k) + side) * h;
}

vec3 end_position(const strip_id& strip, const arc_end& end) {
  vec3 p{end.x, 0, 0};
  p[normal_axis(strip)] = plane_offset(strip);
  p[v_axis(strip)] = line_v(strip, end.side);
  return p;
}

/// The arc's points in its stored order: start root, interior points, end root.
std::vector<vec3> arc_points(const strip_trace& trace, const strip_arc& arc, const strip_id& strip) {
  std::vector<vec3> points{end_position(strip, arc.start)};
  for (std::uint32_t n = 0; n < arc.interior_count; ++n)
    points.push_back(trace.interior[arc.first_interior + n].position);
  points.push_back(end_position(strip, arc.end));
  return points;
}

/// Every root of both lines ends exactly one arc; every arc end is a root of its line.
void expect_each_root_ends_one_arc(const trace_lines& lines, const strip_trace& trace, const strip_id& strip) {
  const std::span<const line_point> roots[2] = {lines.roots_of(strip.low_line()), lines.roots_of(strip.high_line())};
  for (int side = 0; side < 2; ++side) {
    for (const line_point& root : roots[side]) {
      int ends = 0;
      for (const strip_arc& arc : trace.arcs) {
        for (const arc_end& e : {arc.start, arc.end}) ends += e.side == side && e.x == root.x;
      }
      EXPECT_EQ(ends, 1) << "root x = " << root.x << " on side " << side;
    }
  }
  for (const strip_arc& arc : trace.arcs) {
    for (const arc_end& e : {arc.start, arc.end}) {
      EXPECT_GE(lines.match(roots[e.side], e.x), 0) << "arc end x = " << e.x << " is not a root of its line";
    }
  }
}

/// The arcs' interior points lie on the sphere, in the strip's plane, between its lines.
void expect_interior_on_the_contour(const strip_trace& trace, const strip_id& strip) {
  for (const surface_sample& p : trace.interior) {
    EXPECT_NEAR(norm(p.position), radius, 1e-9);
    EXPECT_EQ(p.position[normal_axis(strip)], plane_offset(strip));
    EXPECT_GE(p.position[v_axis(strip)], line_v(strip, 0) - 1e-12);
    EXPECT_LE(p.position[v_axis(strip)], line_v(strip, 1) + 1e-12);
  }
}

/// Each stored arc runs along +(−φ_v, φ_x) (trace_step.hpp's canonical direction): every chord from one point to
/// the next has a positive component along that tangent at its first point (and at its last), ∇φ from the field.
void expect_canonical_direction(const gaussian_field& field, const strip_trace& trace, const strip_id& strip) {
  const int v = v_axis(strip);
  for (const strip_arc& arc : trace.arcs) {
    const std::vector<vec3> points = arc_points(trace, arc, strip);
    ASSERT_GE(points.size(), 2u);
    for (std::size_t n = 0; n + 1 < points.size(); ++n) {
      const vec3 chord = points[n + 1] - points[n];
      for (const vec3& at : {points[n], points[n + 1]}) {
        vec3 g;
        field.value_and_gradient(at, g);
        const double along = chord.x * -g[v] + chord[v] * g.x;
        EXPECT_GT(along, 0) << "arc from x = " << arc.start.x << " (side " << arc.start.side << ") chord " << n;
      }
    }
  }
}

void expect_valid_strip(const gaussian_field& field, const trace_lines& lines, const strip_trace& trace,
                        const strip_id& strip) {
  EXPECT_EQ(trace.failures, 0u);
  expect_each_root_ends_one_arc(lines, trace, strip);
  expect_interior_on_the_contour(trace, strip);
  expect_canonical_direction(field, trace, strip);
  for (const strip_arc& arc : trace.arcs) {
    if (arc.start.side == arc.end.side) {
      EXPECT_GE(arc.interior_count, 1u) << "an arc back to its own line needs an interior point (§7.7)";
    }
    EXPECT_LE(arc.first_interior + arc.interior_count, trace.interior.size());
  }
  if (!trace.arcs.empty()) {
    EXPECT_GT(trace.evaluations, 0u);
  }
}

TEST(strip_arcs, xy_strip_between_two_cut_lines_holds_two_crossing_arcs) {
  const gaussian_field field(one_atom(), -1, 1);
  const trace_lines lines = exact_lines(field);
  const strip_id strip{0, 0, 1};  // plane z = 0.7, lines y = 0 and y = 0.7
  const strip_trace trace = trace_strip(field, lines, strip, settings());
  ASSERT_EQ(trace.arcs.size(), 2u);
  expect_valid_strip(field, lines, trace, strip);
  for (const strip_arc& arc : trace.arcs) {
    EXPECT_NE(arc.start.side, arc.end.side);
    EXPECT_EQ(arc.start.x > 0, arc.end.x > 0);  // each side of the circle links its own two roots
  }
}

TEST(strip_arcs, xz_strip_between_two_cut_lines_holds_two_crossing_arcs) {
  const gaussian_field field(one_atom(), -1, 1);
  const trace_lines lines = exact_lines(field);
  const strip_id strip{1, 1, -1};  // plane y = 0.7, lines z = −0.7 and z = 0
  const strip_trace trace = trace_strip(field, lines, strip, settings());
  ASSERT_EQ(trace.arcs.size(), 2u);
  expect_valid_strip(field, lines, trace, strip);
  for (const strip_arc& arc : trace.arcs) EXPECT_NE(arc.start.side, arc.end.side);
}

TEST(strip_arcs, an_arc_that_returns_to_its_own_line_keeps_an_interior_point) {
  const gaussian_field field(one_atom(), -1, 1);
  const trace_lines lines = exact_lines(field);
  // The high line misses the sphere in each: the contour leaves the low (or high) line and comes back to it over
  // the top of the circle.
  for (const strip_id strip : {strip_id{0, 2, 0}, strip_id{1, 0, 2}, strip_id{0, -3, 1}, strip_id{1, 1, -3}}) {
    SCOPED_TRACE(::testing::Message() << "strip " << strip.orientation << " (" << strip.j << ", " << strip.k << ")");
    ASSERT_TRUE(lines.roots_of(strip.low_line()).empty() != lines.roots_of(strip.high_line()).empty());
    const strip_trace trace = trace_strip(field, lines, strip, settings());
    ASSERT_EQ(trace.arcs.size(), 1u);
    const strip_arc& arc = trace.arcs[0];
    EXPECT_EQ(arc.start.side, arc.end.side);
    EXPECT_NEAR(arc.start.x, -arc.end.x, 1e-12);
    EXPECT_GE(arc.interior_count, 1u);
    // One point at least is the far side of the circle, beyond the chord: not on the line.
    double farthest = 0;
    for (std::uint32_t n = 0; n < arc.interior_count; ++n) {
      const vec3& p = trace.interior[arc.first_interior + n].position;
      farthest = std::max(farthest, std::abs(p[v_axis(strip)] - line_v(strip, arc.start.side)));
    }
    EXPECT_GT(farthest, 0.1);
    expect_valid_strip(field, lines, trace, strip);
  }
}

TEST(strip_arcs, every_strip_of_the_sphere_is_valid) {
  const gaussian_field field(one_atom(), -1, 1);
  const trace_lines lines = exact_lines(field);
  std::size_t arcs = 0, strips = 0;
  for (int orientation = 0; orientation < 2; ++orientation) {
    for (std::int64_t j = -grid - 1; j <= grid; ++j) {
      for (std::int64_t k = -grid - 1; k <= grid; ++k) {
        const strip_id strip{orientation, j, k};
        SCOPED_TRACE(::testing::Message() << "strip " << orientation << " (" << j << ", " << k << ")");
        const strip_trace trace = trace_strip(field, lines, strip, settings());
        const std::size_t roots = lines.roots_of(strip.low_line()).size() + lines.roots_of(strip.high_line()).size();
        EXPECT_EQ(2 * trace.arcs.size(), roots);  // each arc has two ends, each root ends one arc
        expect_valid_strip(field, lines, trace, strip);
              EXPECT_EQ(trace.retraced, 0u);
        arcs += trace.arcs.size();
        strips += !trace.arcs.empty();
      }
    }
  }
  EXPECT_GT(strips, 30u);
  EXPECT_GT(arcs, 50u);
}

// The line roots are complete (line_roots.hpp), so an arc that reaches a line where it has no root went astray: with
// a root taken out of line (1, 1), the arc that would end there is not accepted at the crossing (the strip reports a
// root left without an arc, which fails the line grid), on either line of the strip.
TEST(strip_arcs, a_crossing_where_the_line_has_no_root_is_not_taken_as_a_root) {
  const gaussian_field field(one_atom(), -1, 1);
  struct missing_case {
    strip_id strip;
    line_id line;
    double x;
    int side;
  };
  for (const missing_case& c : {missing_case{{0, 0, 1}, {1, 1}, exact_roots(1, 1)[1], 1},
                                missing_case{{0, 2, 0}, {2, 0}, exact_roots(2, 0)[0], 0}}) {
    const trace_lines lines = exact_lines(field, skipped_root{c.line, c.x});
    const strip_trace trace = trace_strip(field, lines, c.strip, settings());
    EXPECT_GT(trace.failures, 0u);
    for (const strip_arc& arc : trace.arcs) {
      for (const arc_end& e : {arc.start, arc.end}) {
        if (e.side == c.side) {
          EXPECT_GT(std::abs(e.x - c.x), 1e-3);
        }
      }
    }
    // With every root known, the same strip traces completely.
    const trace_lines complete = exact_lines(field);
    const strip_trace again = trace_strip(field, complete, c.strip, settings());
    EXPECT_EQ(again.failures, 0u);
    expect_valid_strip(field, complete, again, c.strip);
  }
}

// The sphere's silhouette in x (the great circle x = 0) passes 0.01 Å outside line (1, 1): the arc of the xy plane
// z = h̃ and that of the xz plane y = h̃ each turn back in x right beside that line, at an extreme point. Both points
// were kept, 0.02 Å apart, and the cell between the two walls joined them by an edge.
TEST(strip_arcs, extreme_points_beside_a_line_are_not_kept) {
  const double spacing = (radius + 0.01) / std::sqrt(2.0);
  const gaussian_field field(one_atom(), -1, 1);
  const trace_lines lines = exact_lines(field, std::nullopt, spacing);
  ASSERT_TRUE(lines.roots_of({1, 1}).empty());
  const strip_trace xy = trace_strip(field, lines, {0, 0, 1}, settings(spacing));
  const strip_trace xz = trace_strip(field, lines, {1, 1, 0}, settings(spacing));
  ASSERT_EQ(xy.arcs.size(), 1u);
  ASSERT_EQ(xz.arcs.size(), 1u);
  EXPECT_GT(closest_pair(xy.interior, xz.interior), 0.1 * spacing);
  for (const strip_trace* t : {&xy, &xz}) {
    for (const surface_sample& p : t->interior) EXPECT_NEAR(norm(p.position), radius, 1e-9);
  }
}

TEST(strip_arcs, a_strip_whose_lines_hold_no_root_is_empty) {
  const gaussian_field field(one_atom(), -1, 1);
  const trace_lines lines = exact_lines(field);
  const strip_trace trace = trace_strip(field, lines, {0, 5, 5}, settings());
  EXPECT_TRUE(trace.arcs.empty());
  EXPECT_TRUE(trace.interior.empty());
  EXPECT_EQ(trace.failures, 0u);
}

/// The lines of `strip` with roots near `low` and `high` (printed by the line root finder to 4 or more decimals),
/// polished here by Newton along x on the exact field.
trace_lines strip_lines_near(const gaussian_field& field, const strip_id& strip, double spacing,
                             const std::vector<double>& low, const std::vector<double>& high) {
  std::vector<trace_lines::entry> entries;
  const auto add = [&](const line_id& line, double x) {
    const double y = static_cast<double>(line.j) * spacing, z = static_cast<double>(line.k) * spacing;
    line_point p{x, {}};
    for (int iteration = 0; iteration < 50; ++iteration) {  // Newton along x on φ − t0
      const double residual = field.value_and_gradient({p.x, y, z}, p.gradient) - field.t0();
      p.x -= residual / p.gradient.x;
    }
    field.value_and_gradient({p.x, y, z}, p.gradient);
    EXPECT_NEAR(p.x, x, 1e-4);
    entries.push_back({line, p});
  };
  for (const double x : low) add(strip.low_line(), x);
  for (const double x : high) add(strip.high_line(), x);
  return trace_lines(std::move(entries));
}

/// mache moved by −shift (the mesher's line grid retries move the molecule, mesher.cpp).
molecule mache_moved_by(const vec3& shift) {
  const result<molecule> mol = read_pqr_file(testing::molecule_path("mache.pqr"));
  EXPECT_TRUE(mol.ok()) << mol.error().message();
  molecule moved = mol.ok() ? *mol : molecule{};
  for (atom& a : moved.atoms) a.center = a.center - shift;
  return moved;
}

/// The arc's vertices in its strip's plane as (x, v): start root, interior points, end root.
std::vector<std::array<double, 2>> arc_polyline(const strip_trace& trace, const strip_arc& arc, const strip_id& strip,
                                                double spacing) {
  const int v = strip.orientation == 0 ? 1 : 2;
  const double low = static_cast<double>(strip.orientation == 0 ? strip.j : strip.k) * spacing;
  std::vector<std::array<double, 2>> out{{arc.start.x, low + arc.start.side * spacing}};
  for (std::uint32_t n = 0; n < arc.interior_count; ++n) {
    const vec3& p = trace.interior[arc.first_interior + n].position;
    out.push_back({p.x, p[v]});
  }
  out.push_back({arc.end.x, low + arc.end.side * spacing});
  return out;
}

/// Closed segments [a, b] and [c, d] of a plane meet (orientation signs; touching counts).
bool segments_meet(const std::array<double, 2>& a, const std::array<double, 2>& b, const std::array<double, 2>& c,
                   const std::array<double, 2>& d) {
  const auto side = [](const std::array<double, 2>& p, const std::array<double, 2>& q, const std::array<double, 2>& r) {
    const double t = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
    return (t > 0) - (t < 0);
  };
  return side(a, b, c) * side(a, b, d) <= 0 && side(c, d, a) * side(c, d, b) <= 0;
}

/// Pairs of straight edges of the strip's arcs that meet, other than neighbours on one arc.
int meeting_edges(const strip_trace& trace, const strip_id& strip, double spacing) {
  std::vector<std::vector<std::array<double, 2>>> lines;
  for (const strip_arc& arc : trace.arcs) lines.push_back(arc_polyline(trace, arc, strip, spacing));
  int meeting = 0;
  for (std::size_t a = 0; a < lines.size(); ++a) {
    for (std::size_t b = a; b < lines.size(); ++b) {
      for (std::size_t i = 0; i + 1 < lines[a].size(); ++i) {
        for (std::size_t j = a == b ? i + 2 : 0; j + 1 < lines[b].size(); ++j) {
          meeting += segments_meet(lines[a][i], lines[a][i + 1], lines[b][j], lines[b][j + 1]);
        }
      }
    }
  }
  return meeting;
}

// mache with a sharp kernel (d = −15, t0 = 1) at 0.5 v/Å² (h̃ = √2 Å): in the xy strip z = −3h̃, y ∈ [−10h̃, −9h̃],
// a small loop of contour leaves the low line at x ≈ −12.6568 and comes back to it at x ≈ −12.7948. The walk from
// −12.7948 dies where the loop turns within a hair; the walk from −12.6568 goes round and ends on −12.7948. That
// root was marked as done by its failed walk, so the good arc was refused too and the cell could not close.
// A root is now free until an arc takes it, whichever end the walk started from.
TEST(strip_arcs, a_root_whose_own_walk_dies_is_reached_from_the_other_end_of_its_contour) {
  const molecule mol = mache_moved_by({0, 0, 0});
  const gaussian_field field(mol, -15, 1);
  const gaussian_field walk_field(mol, -15, 1, 1e-3);  // as the mesher walks (mesher.cpp: trace_walk_tolerance)
  const double spacing = std::sqrt(2.0);
  const strip_id strip{0, -10, -3};
  const trace_lines lines = strip_lines_near(
      field, strip, spacing, {-28.0328, -24.0546, -20.6053, -12.7948, -12.6568, -7.1236, -6.1687, 8.6259, 8.8885, 15.5383},
      {-33.5822, -28.6807, -27.6546, -23.3139, -20.5889, -14.5309, -13.5789, -2.2126, -1.5741, 16.5910});
  strip_settings s = settings(spacing);
  s.cos_bound = trace_parameters{}.cos_bound;
  s.walk_field = &walk_field;
  const strip_trace trace = trace_strip(field, lines, strip, s);
  EXPECT_EQ(trace.failures, 0u);
  EXPECT_FALSE(trace.level_shifted);
  expect_each_root_ends_one_arc(lines, trace, strip);
}

// villin_1vii at d = −15, t0 = 3, 1 v/Å² (h̃ = 0.93 Å, points kept 1.15 h̃ apart): the xz strip y = −8h̃,
// z ∈ [2h̃, 3h̃] is tangent to the surface where the contour crosses itself, and walks die there however short
// their steps. Traced at t0·(1 ± 1e-3), where the crossing splits, every root ends one arc, and
// the arcs' points are back on φ = t0.
TEST(strip_arcs, a_contour_that_crosses_itself_is_traced_at_a_level_next_to_t0) {
  const result<molecule> mol = read_pqr_file(testing::molecule_path("villin_1vii.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  const gaussian_field field(*mol, -15, 3);
  const gaussian_field walk_field(*mol, -15, 3, 1e-3);  // as the mesher walks (mesher.cpp: trace_walk_tolerance)
  const double spacing = 0.93;
  const strip_id strip{1, -8, 2};
  const trace_lines lines = strip_lines_near(
      field, strip, spacing,
      {-10.804457236836125, -3.5405870229442038, -2.0345705295044887, 3.4197743036937309, 5.0169765582210157,
       8.6867659660096077},
      {-10.762993281491157, -2.2734229486506861, -1.6787166697424087, 10.538395190936015});
  const trace_parameters defaults;
  strip_settings s = settings(spacing);
  s.max_step = defaults.step_fraction * spacing;
  s.cos_bound = defaults.cos_bound;
  s.extreme_tolerance = defaults.extreme_tolerance;
  s.resample_spacing = 1.15 * spacing;
  s.walk_field = &walk_field;
  const strip_trace trace = trace_strip(field, lines, strip, s);
  EXPECT_EQ(trace.failures, 0u);
  EXPECT_TRUE(trace.level_shifted);
  EXPECT_GT(trace.retraced, 0u);
  expect_each_root_ends_one_arc(lines, trace, strip);
  for (const surface_sample& p : trace.interior) {
    EXPECT_EQ(p.position.y, -8 * spacing);
    EXPECT_LT(field.surface_distance(p.position), 1e-9) << p.position.x << " " << p.position.z;
    EXPECT_GT(p.position.z, 2 * spacing);
    EXPECT_LT(p.position.z, 3 * spacing);
  }
}

// fas2 at d = −20, t0 = 0.1, 0.5 v/Å² (h̃ = 0.93·√2 Å, points kept 1.15 h̃ apart): in the xz strip y = 4h̃,
// z ∈ [24h̃, 25h̃], the arc from the root at x ≈ −9.384 runs into a crevice between sharp atoms, a hairpin about
// 0.07 Å wide and 1.9 Å deep, and back out. Its kept points, joined by straight edges, made the edge leaving the
// hairpin cross the one entering it, and the cells on both sides of the strip could not close their loops on any
// line grid. Edges that cross now keep the walk point farthest from their chord until no two
// edges of the strip meet.
TEST(strip_arcs, the_straight_edges_of_a_hairpin_narrower_than_their_sagitta_are_untangled) {
  const result<molecule> mol = read_pqr_file(testing::molecule_path("fas2.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  const gaussian_field field(*mol, -20, 0.1);
  const gaussian_field walk_field(*mol, -20, 0.1, 1e-3);  // as the mesher walks (mesher.cpp: trace_walk_tolerance)
  const double spacing = 0.93 * std::sqrt(2.0);
  const strip_id strip{1, 4, 24};
  const trace_lines lines = strip_lines_near(
      field, strip, spacing,
      {-19.458555994842179, -9.3836037053435071, -7.0888683559044585, 2.0991191789470074, 2.7428769284129202,
       5.1671516640090154},
      {-19.352641319546251, -16.847896319262539, -15.800431615671723, -8.8137172429077548, -6.8654923631238933,
       2.3131843097416271});
  const trace_parameters defaults;
  strip_settings s = settings(spacing);
  s.max_step = defaults.step_fraction * spacing;
  s.cos_bound = defaults.cos_bound;
  s.extreme_tolerance = defaults.extreme_tolerance;
  s.resample_spacing = 1.15 * spacing;
  s.walk_field = &walk_field;
  const strip_trace trace = trace_strip(field, lines, strip, s);
  EXPECT_EQ(trace.failures, 0u);
  expect_each_root_ends_one_arc(lines, trace, strip);
  EXPECT_GT(trace.untangled_points, 0u);
  EXPECT_EQ(meeting_edges(trace, strip, spacing), 0);
  for (const surface_sample& p : trace.interior) {
    EXPECT_EQ(p.position.y, 4 * spacing);
    EXPECT_LT(field.surface_distance(p.position), 1e-9) << p.position.x << " " << p.position.z;
  }
}

}  // namespace
}  // namespace tracemesh
