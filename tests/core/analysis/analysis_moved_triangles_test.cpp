// The certificate's tests on the triangles an edit moved (core/analysis/analysis_moved_triangles.hpp), on loose
// triangles whose crossings are known: two triangles that pierce each other, one far away, one degenerate.
#include "core/analysis/analysis_moved_triangles.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace tracemesh {
namespace {

/// Triangle 0 in the plane z = 0 around the origin; triangle 1 standing across it (they pierce each other);
/// triangle 2 far away; triangle 3 degenerate (its corners on a line), also far away.
surface_mesh loose_triangles() {
  surface_mesh m;
  m.positions = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0},          // 0
                 {0, 0, -1},  {0.2, 0, 1}, {-0.2, 0.1, 1},    // 1: crosses z = 0 inside triangle 0
                 {10, 0, 0},  {11, 0, 0},  {10, 1, 0},        // 2
                 {20, 0, 0},  {21, 0, 0},  {22, 0, 0}};       // 3
  m.triangles = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}, {9, 10, 11}};
  return m;
}

TEST(analysis_moved_triangles, a_moved_triangle_that_pierces_a_still_one_fails_alone) {
  // Only moved triangles are reported: the still one was there before the edit.
  EXPECT_EQ(detail::failing_moved_triangles(loose_triangles(), {}, {1}), (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(detail::failing_moved_triangles(loose_triangles(), {}, {0}), (std::vector<std::uint32_t>{0}));
  EXPECT_EQ(detail::failing_moved_triangles(loose_triangles(), {}, {1, 0}), (std::vector<std::uint32_t>{0, 1}));
}

TEST(analysis_moved_triangles, a_moved_triangle_clear_of_the_others_passes) {
  EXPECT_TRUE(detail::failing_moved_triangles(loose_triangles(), {}, {2}).empty());
}

TEST(analysis_moved_triangles, a_degenerate_moved_triangle_fails) {
  EXPECT_EQ(detail::failing_moved_triangles(loose_triangles(), {}, {2, 3}), (std::vector<std::uint32_t>{3}));
}

TEST(analysis_moved_triangles, a_removed_triangle_is_not_tested_against) {
  const std::vector<char> alive{0, 1, 1, 1};
  EXPECT_TRUE(detail::failing_moved_triangles(loose_triangles(), alive, {1}).empty());
}

TEST(analysis_moved_triangles, among_tests_only_the_triangles_it_is_given) {
  EXPECT_EQ(detail::failing_moved_triangles_among(loose_triangles(), {1}, {0}), (std::vector<std::uint32_t>{1}));
  // Triangle 0 pierces 1 but is not among the others: no search of the mesh finds it.
  EXPECT_TRUE(detail::failing_moved_triangles_among(loose_triangles(), {1}, {2}).empty());
  EXPECT_EQ(detail::failing_moved_triangles_among(loose_triangles(), {1, 0}, {}), (std::vector<std::uint32_t>{0, 1}));
}

TEST(analysis_moved_triangles, again_tests_only_the_pairs_with_a_triangle_to_retest) {
  const surface_mesh m = loose_triangles();
  // Triangle 1 passed before and triangle 0 is as it was: the pair is not tested again.
  EXPECT_TRUE(detail::failing_moved_triangles_again(m, {}, {1}, {}).empty());
  // Triangle 0 changed since: it is tested against 1, and 1, the moved one, is reported (0 did not move).
  EXPECT_EQ(detail::failing_moved_triangles_again(m, {}, {1}, {0}), (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(detail::failing_moved_triangles_again(m, {}, {0, 1}, {0}), (std::vector<std::uint32_t>{0, 1}));
  // A degenerate triangle fails when it is to be retested; one that passed before is not looked at again.
  EXPECT_EQ(detail::failing_moved_triangles_again(m, {}, {2, 3}, {3}), (std::vector<std::uint32_t>{3}));
  EXPECT_TRUE(detail::failing_moved_triangles_again(m, {}, {2, 3}, {2}).empty());
}

}  // namespace
}  // namespace tracemesh
