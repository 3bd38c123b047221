// Tests of core/trace/trace_step.hpp (paper Algorithm 1) on one atom, whose contours are circles known in closed form:
// with d = −1 and t0 = 1 the surface of a lone atom of radius r is the sphere of radius r, so the plane z = z₀ cuts it
// in the circle of radius ρ = √(r² − z₀²), which crosses the line y = v at x = ±√(ρ² − v²).
#include "core/trace/trace_step.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/field/gaussian_field.hpp"
#include "core/molecule.hpp"

namespace tracemesh {
namespace {

constexpr double atom_radius = 1.5;
constexpr double plane_z = 0.3;

molecule lone_atom() {
  molecule mol;
  mol.atoms.push_back({{0, 0, 0}, atom_radius, 0});
  return mol;
}

double contour_radius() { return std::sqrt(atom_radius * atom_radius - plane_z * plane_z); }

surface_sample sample_at(const gaussian_field& field, vec3 p) {
  surface_sample s{p, {}, false};
  field.value_and_gradient(p, s.gradient);
  return s;
}

/// A strip between the lines y = 0.2 and y = 1.2 of the plane z = plane_z, walked with steps of at most 0.25 Å.
trace_step_settings strip_from_0_2_to_1_2() {
  trace_step_settings settings;
  settings.v_low = 0.2;
  settings.v_high = 1.2;
  settings.max_step = 0.25;
  return settings;
}

/// The contour's crossing of the low line y = 0.2 at x > 0.
surface_sample start_on_the_low_line(const gaussian_field& field) {
  const double rho = contour_radius();
  return sample_at(field, {std::sqrt(rho * rho - 0.04), 0.2, plane_z});
}

TEST(trace_step, walks_a_circle_to_the_next_line_where_the_closed_form_says) {
  const gaussian_field field(lone_atom(), -1, 1);
  const double rho = contour_radius();
  const trace_step_settings settings = strip_from_0_2_to_1_2();
  const surface_sample start = start_on_the_low_line(field);
  // Into +y from the low line: s·φ_x > 0, and φ_x < 0 at x > 0.
  std::size_t evaluations = 0;
  const traced_arc arc = trace_contour(field, {2, plane_z}, start, -1, settings, evaluations);
  ASSERT_EQ(arc.end, trace_end::high_line);
  const vec3 end = arc.points.back().position;
  EXPECT_NEAR(end.x, std::sqrt(rho * rho - 1.44), 1e-9);
  EXPECT_DOUBLE_EQ(end.y, 1.2);
  EXPECT_DOUBLE_EQ(end.z, plane_z);
  // Walk points are corrected to within settings.corrector_tolerance (or a blind step's second-order error) of the
  // contour; the start and the crossing are exact roots.
  for (const surface_sample& p : arc.points) {
    EXPECT_NEAR(std::hypot(p.position.x, p.position.y), rho, 1e-6);
    EXPECT_EQ(p.position.z, plane_z);  // the walk never leaves its plane
  }
  EXPECT_NEAR(std::hypot(end.x, end.y), rho, 1e-10);
  // Steps are at most h₁ and the normal turns by at most acos δ per step.
  for (std::size_t n = 1; n < arc.points.size(); ++n) {
    EXPECT_LE(distance(arc.points[n - 1].position, arc.points[n].position), settings.max_step * 1.0001);
  }
  EXPECT_GT(evaluations, arc.points.size());
}

// A crossing with exactly one known root of its line nearby arrives at that root without Newton on the line (its x
// and gradient are the root's, bit for bit); with a second root close by, Newton decides.
TEST(trace_step, a_lone_known_root_near_the_crossing_is_taken_without_polishing) {
  const gaussian_field field(lone_atom(), -1, 1);
  const double rho = contour_radius();
  trace_step_settings settings = strip_from_0_2_to_1_2();
  const surface_sample start = start_on_the_low_line(field);
  std::size_t polished_evaluations = 0;
  const traced_arc polished = trace_contour(field, {2, plane_z}, start, -1, settings, polished_evaluations);
  ASSERT_EQ(polished.end, trace_end::high_line);

  // The exact root, with a gradient that is recognisably the caller's (scaled by 2): it must be used as given.
  const double root_x = std::sqrt(rho * rho - 1.44);
  const surface_sample root = sample_at(field, {root_x, 1.2, plane_z});
  const std::vector<line_point> lone{{-root_x, root.gradient}, {root_x, 2.0 * root.gradient}};
  settings.high_roots = lone;
  std::size_t known_evaluations = 0;
  const traced_arc known = trace_contour(field, {2, plane_z}, start, -1, settings, known_evaluations);
  ASSERT_EQ(known.end, trace_end::high_line);
  EXPECT_EQ(known.points.back().position.x, root_x);
  EXPECT_EQ(known.points.back().gradient.x, 2.0 * root.gradient.x);
  EXPECT_LT(known_evaluations, polished_evaluations);

  // A second root 0.02 Å away (a near-tangency): the walk polishes and finds the exact crossing itself.
  const std::vector<line_point> pair{{root_x - 0.02, root.gradient}, {root_x + 1e-3, 2.0 * root.gradient}};
  settings.high_roots = pair;
  std::size_t pair_evaluations = 0;
  const traced_arc decided = trace_contour(field, {2, plane_z}, start, -1, settings, pair_evaluations);
  ASSERT_EQ(decided.end, trace_end::high_line);
  EXPECT_NEAR(decided.points.back().position.x, root_x, 1e-9);
  EXPECT_NE(decided.points.back().gradient.x, 2.0 * root.gradient.x);
}

// A walk on an approximate field whose last step lands past a line with a lone known root next to the chord's
// crossing takes that root without correcting the step on the exact field: it costs exactly the walk field's own
// evaluations, as the same walk made on the walk field alone.
TEST(trace_step, a_step_that_arrives_at_a_lone_known_root_is_not_corrected_on_the_exact_field) {
  const gaussian_field field(lone_atom(), -1, 1);
  const gaussian_field walk(lone_atom(), -1, 1.01);
  const double rho = contour_radius();
  trace_step_settings settings = strip_from_0_2_to_1_2();
  settings.exact_near_line = 0;  // only points past a line are candidates for the exact field
  const double root_x = std::sqrt(rho * rho - 1.44);
  const std::vector<line_point> lone{{root_x, sample_at(field, {root_x, 1.2, plane_z}).gradient}};
  settings.high_roots = lone;
  const surface_sample start = start_on_the_low_line(field);

  std::size_t walk_alone = 0;
  const traced_arc reference = trace_contour(walk, {2, plane_z}, start, -1, settings, walk_alone);
  settings.walk_field = &walk;
  std::size_t on_walk_field = 0;
  const traced_arc arc = trace_contour(field, {2, plane_z}, start, -1, settings, on_walk_field);
  ASSERT_EQ(arc.end, trace_end::high_line);
  EXPECT_EQ(arc.points.back().position.x, root_x);
  EXPECT_EQ(on_walk_field, walk_alone);
  ASSERT_EQ(arc.points.size(), reference.points.size());

  // Without the known root the crossing is decided on the exact field: the step is corrected and polished there.
  settings.high_roots = {};
  std::size_t decided = 0;
  const traced_arc polished = trace_contour(field, {2, plane_z}, start, -1, settings, decided);
  ASSERT_EQ(polished.end, trace_end::high_line);
  EXPECT_NEAR(polished.points.back().position.x, root_x, 1e-9);
  EXPECT_GT(decided, on_walk_field);
}

// The walk may run on an approximate field (here: another isovalue, so its contour is a visibly different circle);
// points that land within exact_near_line of a line, and the crossing, are on the exact contour.
TEST(trace_step, walks_on_the_walk_field_and_decides_near_lines_on_the_exact_one) {
  const gaussian_field field(lone_atom(), -1, 1);
  const gaussian_field walk(lone_atom(), -1, 1.01);
  const double rho = contour_radius();
  const double walk_rho = std::sqrt(atom_radius * atom_radius * (1 - std::log(1.01)) - plane_z * plane_z);
  ASSERT_GT(rho - walk_rho, 5e-3);
  trace_step_settings settings = strip_from_0_2_to_1_2();
  settings.max_step = 0.1;
  settings.walk_field = &walk;
  settings.exact_near_line = 0.15;  // wider than a step: some walk points surely land in it
  const surface_sample start = start_on_the_low_line(field);
  std::size_t evaluations = 0;
  const traced_arc arc = trace_contour(field, {2, plane_z}, start, -1, settings, evaluations);
  ASSERT_EQ(arc.end, trace_end::high_line);
  EXPECT_NEAR(arc.points.back().position.x, std::sqrt(rho * rho - 1.44), 1e-9);
  int on_walk = 0, near_line = 0;
  for (std::size_t n = 1; n + 1 < arc.points.size(); ++n) {
    const vec3& p = arc.points[n].position;
    const double r = std::hypot(p.x, p.y);
    if (p.y - settings.v_low < settings.exact_near_line || settings.v_high - p.y < settings.exact_near_line) {
      ++near_line;
      EXPECT_NEAR(r, rho, 2 * settings.corrector_tolerance) << "at y = " << p.y;
    } else {
      ++on_walk;
      EXPECT_NEAR(r, walk_rho, 2 * settings.corrector_tolerance) << "at y = " << p.y;
    }
  }
  EXPECT_GT(on_walk, 5);
  EXPECT_GE(near_line, 1);
}

TEST(trace_step, returns_to_the_same_line_through_an_extreme_point) {
  const gaussian_field field(lone_atom(), -1, 1);
  const double rho = contour_radius();
  trace_step_settings settings;
  settings.v_low = 0.2;
  settings.v_high = 1.6;  // beyond the circle: the contour turns back to y = 0.2
  settings.max_step = 0.3;
  settings.extreme_tolerance = 0.02;
  const double x0 = std::sqrt(rho * rho - 0.04);
  std::size_t evaluations = 0;
  const traced_arc arc = trace_contour(field, {2, plane_z}, sample_at(field, {x0, 0.2, plane_z}), -1, settings, evaluations);
  ASSERT_EQ(arc.end, trace_end::low_line);
  EXPECT_NEAR(arc.points.back().position.x, -x0, 1e-9);
  int extremes = 0;
  for (const surface_sample& p : arc.points) {
    if (!p.extreme) continue;
    ++extremes;
    EXPECT_NEAR(p.position.x, 0.0, 0.03 * rho);  // φ_x ≈ 0 at the top of the circle
    EXPECT_NEAR(p.position.y, rho, 1e-3);
  }
  EXPECT_EQ(extremes, 1);
}

TEST(trace_step, the_opposite_sign_walks_the_other_way_in_an_xz_plane) {
  const gaussian_field field(lone_atom(), -1, 1);
  const double rho = contour_radius();  // plane y = 0.3 this time
  trace_step_settings settings;
  settings.v_low = -0.5;
  settings.v_high = 0.5;
  settings.max_step = 0.2;
  const double x0 = std::sqrt(rho * rho - 0.25);
  std::size_t evaluations = 0;
  // From (x0, 0.3, 0.5) on the high line into −z: s·φ_x < 0 with φ_x < 0 → s = +1.
  const traced_arc arc =
      trace_contour(field, {1, plane_z}, sample_at(field, {x0, plane_z, 0.5}), 1, settings, evaluations);
  ASSERT_EQ(arc.end, trace_end::low_line);
  EXPECT_NEAR(arc.points.back().position.x, x0, 1e-9);
  EXPECT_DOUBLE_EQ(arc.points.back().position.z, -0.5);
  for (const surface_sample& p : arc.points) EXPECT_EQ(p.position.y, plane_z);
}

TEST(trace_step, polishing_on_a_line_finds_the_crossing) {
  const gaussian_field field(lone_atom(), -1, 1);
  surface_sample out;
  std::size_t evaluations = 0;
  ASSERT_TRUE(polish_on_line(field, {1.2, 0.4, plane_z}, 0.5, out, evaluations));
  EXPECT_NEAR(out.position.x, std::sqrt(atom_radius * atom_radius - 0.16 - plane_z * plane_z), 1e-10);
  EXPECT_FALSE(polish_on_line(field, {1.2, 1.6, plane_z}, 0.5, out, evaluations));  // the line misses the sphere
}

// With d = −1 a lone atom's φ = t0 + s is the sphere of atom_radius r·√(1 − ln(1 + s/t0)): the walk and the polishing
// at a shifted level (a strip whose contour crosses itself at t0, strip_arcs.cpp) follow that sphere instead.
TEST(trace_step, a_shifted_level_is_walked_and_polished_on_its_own_contour) {
  const gaussian_field field(lone_atom(), -1, 1);
  const double shift = 0.05;
  const double shifted_radius = atom_radius * std::sqrt(1 - std::log(1 + shift));
  const double rho = std::sqrt(shifted_radius * shifted_radius - plane_z * plane_z);
  surface_sample start;
  std::size_t evaluations = 0;
  ASSERT_TRUE(polish_on_line(field, {1.2, 0.2, plane_z}, 0.5, start, evaluations, shift));
  EXPECT_NEAR(start.position.x, std::sqrt(rho * rho - 0.04), 1e-10);
  const traced_arc arc =
      trace_contour(field, {2, plane_z, shift}, start, -1, strip_from_0_2_to_1_2(), evaluations);
  ASSERT_EQ(arc.end, trace_end::high_line);
  EXPECT_NEAR(arc.points.back().position.x, std::sqrt(rho * rho - 1.44), 1e-9);
  for (const surface_sample& p : arc.points) EXPECT_NEAR(norm(p.position), shifted_radius, 1e-4);
  // The same polishing at t0 lands on the unshifted sphere, farther out.
  surface_sample unshifted;
  ASSERT_TRUE(polish_on_line(field, {1.2, 0.2, plane_z}, 0.5, unshifted, evaluations));
  EXPECT_NEAR(norm(unshifted.position), atom_radius, 1e-10);
  EXPECT_GT(unshifted.position.x, start.position.x + 0.01);
}

}  // namespace
}  // namespace tracemesh
