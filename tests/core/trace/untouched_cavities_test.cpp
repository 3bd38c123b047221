// Tests of core/trace/untouched_cavities.hpp: a void between the lines is found from a seed near it, proven alone
// in a box, and left alone when a line already meets it or when it opens to the outside; the face proof against a
// single atom's closed form.
#include "core/trace/untouched_cavities.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "support/shell_molecule.hpp"

namespace tracemesh {
namespace {

// The void of trace_mesher_test's shell: 100 atoms of radius 2.07 on a sphere of radius 5 around (0.13, 0.5, 0.5)
// leave a void of radius ≈ 0.61 Å (φ ≈ 0.80 at its centre) between the lines of h̃ = 1, which pass 0.71 Å from it.
const vec3 void_centre{0.13, 0.5, 0.5};
molecule shell_around_a_small_void() { return testing::fibonacci_shell(100, 5, 2.07, void_centre); }

/// Seeds on the four lines around the void, where they pass closest to it.
std::vector<vec3> seeds_beside_the_void() {
  return {{0.13, 0, 0}, {0.13, 1, 0}, {0.13, 0, 1}, {0.13, 1, 1}};
}

/// One atom of radius 2 at the origin.
molecule lone_atom_of_radius_2() {
  molecule one;
  one.atoms.push_back({{0, 0, 0}, 2.0, 0});
  return one;
}

/// find_untouched_cavities with default settings and a token that is never cancelled.
std::vector<untouched_cavity> search(const gaussian_field& field, const trace_lines& lines, double h,
                                     const std::vector<vec3>& seeds, untouched_cavity_stats& stats) {
  progress_token progress;
  return find_untouched_cavities(field, lines, h, seeds, {}, progress, stats);
}

bool inside(const box3& box, const vec3& p) {
  return p.x > box.lo.x && p.x < box.hi.x && p.y > box.lo.y && p.y < box.hi.y && p.z > box.lo.z && p.z < box.hi.z;
}

TEST(untouched_cavities, a_void_between_the_lines_is_found_and_proven_alone_in_its_box) {
  const gaussian_field field(shell_around_a_small_void(), -1, 1);
  untouched_cavity_stats stats;
  const auto found = search(field, trace_lines{}, 1.0, seeds_beside_the_void(), stats);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(stats.seeds, 4u);
  EXPECT_EQ(stats.pockets, 1u) << "the four descents end at one minimum";
  const untouched_cavity& c = found[0];

  // A minimum of φ below t0, near the shell's centre (the Fibonacci shell is not exactly symmetric).
  vec3 gradient;
  EXPECT_LT(field.value_and_gradient(c.minimum, gradient), field.value(void_centre) + 1e-12);
  EXPECT_LT(norm(gradient), 1e-6);
  EXPECT_LT(distance(c.minimum, void_centre), 0.1);

  // The local grid: whole blocks, a line through the minimum, spacing at most h̃/2.
  const double block = 8 * c.spacing;
  EXPECT_LE(c.spacing, 0.5);
  EXPECT_NEAR(c.box.hi.y - c.box.lo.y, c.blocks_yz * block, 1e-12);
  EXPECT_NEAR(c.box.hi.z - c.box.lo.z, c.blocks_yz * block, 1e-12);
  EXPECT_NEAR(c.box.hi.x - c.box.lo.x, c.blocks_x * block, 1e-12);
  EXPECT_NEAR(c.box.lo.y + 4 * c.blocks_yz * c.spacing, c.minimum.y, 1e-12);
  EXPECT_NEAR(c.box.lo.z + 4 * c.blocks_yz * c.spacing, c.minimum.z, 1e-12);

  // Independently of the bounds: φ > t0 on a fine grid of every face, and the void (marched from the minimum in
  // 26 directions to where φ reaches t0) inside the box.
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      for (int u = 0; u <= 60; ++u) {
        for (int v = 0; v <= 60; ++v) {
          vec3 p;
          const int a = (axis + 1) % 3, b = (axis + 2) % 3;
          p[axis] = side == 0 ? c.box.lo[axis] : c.box.hi[axis];
          p[a] = c.box.lo[a] + (c.box.hi[a] - c.box.lo[a]) * u / 60.0;
          p[b] = c.box.lo[b] + (c.box.hi[b] - c.box.lo[b]) * v / 60.0;
          ASSERT_GT(field.value(p), field.t0()) << "face " << axis << side;
        }
      }
    }
  }
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const vec3 direction = normalized(vec3{double(dx), double(dy), double(dz)});
        double t = 0;
        while (field.value(c.minimum + direction * t) < field.t0()) t += 1e-3;
        EXPECT_TRUE(inside(c.box, c.minimum + direction * t));
        EXPECT_GT(t, 0.3) << "the void is about 0.6 Å in radius";
      }
    }
  }
}

TEST(untouched_cavities, a_void_that_a_line_meets_is_left_to_the_lines) {
  const gaussian_field field(shell_around_a_small_void(), -1, 1);
  untouched_cavity_stats stats;
  // Lines of spacing 0.5: line (1, 1) passes through the void's centre and holds its two roots.
  const trace_lines lines({{{1, 1}, {void_centre.x - 0.5, {}}}, {{1, 1}, {void_centre.x + 0.5, {}}}});
  EXPECT_TRUE(search(field, lines, 0.5, {{0.13, 0, 0}, {0.13, 1, 1}}, stats).empty());
  EXPECT_EQ(stats.pockets, 1u) << "the pocket is found, then left to the lines";
}

TEST(untouched_cavities, a_pocket_open_to_the_outside_is_not_a_cavity) {
  // The same shell without the atoms more than 3 Å above its centre: φ still has a minimum below t0 inside, but
  // the pocket around it opens upwards into the outside (checked below along the vertical).
  const gaussian_field field(testing::fibonacci_shell(100, 5, 2.07, void_centre, 3.0), -1, 1);
  for (double t = 0; t < 10; t += 0.01) ASSERT_LT(field.value(void_centre + vec3{0, 0, t}), field.t0()) << t;
  untouched_cavity_stats stats;
  EXPECT_TRUE(search(field, trace_lines{}, 1.0, seeds_beside_the_void(), stats).empty());
  EXPECT_EQ(stats.pockets, 1u);
}

TEST(untouched_cavities, seeds_whose_descent_stays_above_the_level_find_nothing) {
  // One atom: φ has its only minimum at infinity; a descent from inside leaves along the radius.
  const gaussian_field field(lone_atom_of_radius_2(), -1, 1);
  untouched_cavity_stats stats;
  EXPECT_TRUE(search(field, trace_lines{}, 1.0, {{0.5, 0.25, 0}, {0, 1, 1}}, stats).empty());
  EXPECT_EQ(stats.pockets, 0u);
}

// One atom of radius 2 at the origin, d = −1, t0 = 1: φ = exp(1 − ρ²/4) > 1 exactly where ρ < 2. A cube of half
// width a has its farthest points (the corners) at ρ = a√3.
TEST(untouched_cavities, the_face_proof_follows_the_closed_form_of_one_atom) {
  const gaussian_field field(lone_atom_of_radius_2(), -1, 1);
  const auto cube = [](double a) { return box3{{-a, -a, -a}, {a, a, a}}; };
  EXPECT_TRUE(box_faces_above_level(field, cube(1.0), 1e-3));  // corners at ρ = 1.73
  EXPECT_TRUE(box_faces_above_level(field, cube(1.15), 1e-3));  // ρ = 1.992: φ = 1.008 at the corners
  EXPECT_FALSE(box_faces_above_level(field, cube(1.16), 1e-3));  // ρ = 2.009: the corners are outside
  EXPECT_FALSE(box_faces_above_level(field, cube(3.0), 1e-3));   // the faces cross the sphere
  // A box off the centre whose nearest face still lies inside the sphere and farthest corner outside it.
  EXPECT_FALSE(box_faces_above_level(field, box3{{0.5, -0.5, -0.5}, {2.5, 0.5, 0.5}}, 1e-3));
}

/// Eight atoms of radius 1.5 at the corners (±1.2, ±1.2, ±1.2): at the centre their gradients cancel.
molecule cube_of_eight_atoms() {
  molecule eight;
  for (const double x : {-1.2, 1.2}) {
    for (const double y : {-1.2, 1.2}) {
      for (const double z : {-1.2, 1.2}) eight.atoms.push_back({{x, y, z}, 1.5, 0});
    }
  }
  return eight;
}

/// The least of φ over a grid of n × n points on each face of `box`.
double least_on_faces(const gaussian_field& field, const box3& box, int n) {
  double least = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    for (const double side : {box.lo[axis], box.hi[axis]}) {
      for (int u = 0; u < n; ++u) {
        for (int v = 0; v < n; ++v) {
          vec3 p;
          p[axis] = side;
          p[a] = box.lo[a] + (box.hi[a] - box.lo[a]) * u / (n - 1);
          p[b] = box.lo[b] + (box.hi[b] - box.lo[b]) * v / (n - 1);
          least = std::min(least, field.value(p));
        }
      }
    }
  }
  return least;
}

// Among atoms whose pulls cancel, the centred form of the bound proves a face that the per-atom extremes of eqs. 3–5
// cannot without cutting it: on the faces of the cube of half width 0.3 around the centre, φ ≥ 3.22, the centred form
// gives 2.05 on a whole face and eqs. 3–5 only 1.57. With patches no smaller than the face, t0 = 1.8 is proven.
TEST(untouched_cavities, the_face_proof_keeps_the_cancellation_between_atoms) {
  const box3 cube{{-0.3, -0.3, -0.3}, {0.3, 0.3, 0.3}};
  const gaussian_field field(cube_of_eight_atoms(), -1, 1.8);
  ASSERT_GT(least_on_faces(field, cube, 61), 3.2);
  EXPECT_TRUE(box_faces_above_level(field, cube, 1.0));
}

// The proof is sound: whatever t0, a box it proves has φ above t0 at every sampled point of its faces, and one whose
// faces dip to t0 is refused.
TEST(untouched_cavities, a_proven_face_is_above_the_level_at_every_sample) {
  const molecule eight = cube_of_eight_atoms();
  for (const double half : {0.2, 0.4, 0.6, 0.9}) {
    const box3 cube{{-half, -half, -half}, {half, half, half}};
    const double least = least_on_faces(gaussian_field(eight, -1, 1), cube, 81);
    for (const double fraction : {0.5, 0.8, 0.95, 0.999, 1.001, 1.2}) {
      const double t0 = fraction * least;
      const gaussian_field field(eight, -1, t0);
      const bool proven = box_faces_above_level(field, cube, 1e-3);
      if (fraction > 1) {
        EXPECT_FALSE(proven) << "half width " << half << ", t0 " << t0;
      } else if (fraction <= 0.95) {
        EXPECT_TRUE(proven) << "half width " << half << ", t0 " << t0;
      }
    }
  }
}

}  // namespace
}  // namespace tracemesh
