// Tests of core/trace/trace_lines.hpp: the roots of the trace path's lines, merged, sorted and numbered.
#include "core/trace/trace_lines.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace tracemesh {
namespace {

using entry = trace_lines::entry;

entry root(std::int64_t j, std::int64_t k, double x) { return {{j, k}, {x, {x, 2.0 * x, 3.0 * x}}}; }

std::vector<double> xs(std::span<const line_point> roots) {
  std::vector<double> out;
  for (const line_point& p : roots) out.push_back(p.x);
  return out;
}

TEST(trace_lines, sorts_lines_by_j_then_k_and_roots_by_x) {
  const trace_lines lines({root(1, 0, 2.0), root(0, 1, 5.0), root(1, 0, -3.0), root(0, 1, -1.0), root(-2, 7, 0.5)});
  ASSERT_EQ(lines.line_count(), 3u);
  ASSERT_EQ(lines.root_count(), 5u);
  EXPECT_EQ(lines.id(0), (line_id{-2, 7}));
  EXPECT_EQ(lines.id(1), (line_id{0, 1}));
  EXPECT_EQ(lines.id(2), (line_id{1, 0}));
  EXPECT_EQ(xs(lines.roots(0)), (std::vector<double>{0.5}));
  EXPECT_EQ(xs(lines.roots(1)), (std::vector<double>{-1.0, 5.0}));
  EXPECT_EQ(xs(lines.roots(2)), (std::vector<double>{-3.0, 2.0}));
  // The gradient travels with its root.
  EXPECT_EQ(lines.roots(2)[0].gradient, (vec3{-3.0, -6.0, -9.0}));
}

TEST(trace_lines, duplicate_roots_within_the_merge_tolerance_are_kept_once) {
  constexpr double tol = trace_lines::merge_tolerance;
  const trace_lines lines({root(0, 0, 1.0), root(0, 0, 1.0 + 0.4 * tol), root(0, 0, 1.0),  // one root
                           root(0, 0, 1.0 + 3 * tol),                                      // a distinct one
                           root(0, 1, 1.0 + 0.4 * tol)});  // the same x on another line is not a duplicate
  ASSERT_EQ(lines.line_count(), 2u);
  EXPECT_EQ(lines.roots_of({0, 0}).size(), 2u);
  EXPECT_EQ(lines.roots_of({0, 0})[0].x, 1.0);  // the smallest of the merged group is kept
  EXPECT_EQ(lines.roots_of({0, 0})[1].x, 1.0 + 3 * tol);
  EXPECT_EQ(lines.roots_of({0, 1}).size(), 1u);
  EXPECT_EQ(lines.root_count(), 3u);
}

TEST(trace_lines, roots_just_beyond_the_tolerance_stay_apart) {
  constexpr double tol = trace_lines::merge_tolerance;
  const trace_lines lines({root(0, 0, 0.0), root(0, 0, 1.5 * tol), root(0, 0, -1.5 * tol)});
  EXPECT_EQ(lines.root_count(), 3u);
}

TEST(trace_lines, match_finds_the_nearest_root_within_the_tolerance) {
  constexpr double tol = trace_lines::merge_tolerance;
  const trace_lines lines({root(3, 4, -2.0), root(3, 4, 0.0), root(3, 4, 1.0), root(3, 4, 1.0 + 5 * tol)});
  const std::span<const line_point> roots = lines.roots_of({3, 4});
  ASSERT_EQ(roots.size(), 4u);
  EXPECT_EQ(lines.match(roots, -2.0), 0);
  EXPECT_EQ(lines.match(roots, 0.0 + 0.5 * tol), 1);
  EXPECT_EQ(lines.match(roots, 0.0 - 0.5 * tol), 1);
  EXPECT_EQ(lines.match(roots, 1.0 + 0.9 * tol), 2);
  EXPECT_EQ(lines.match(roots, 1.0 + 4.5 * tol), 3);
  EXPECT_EQ(lines.match(roots, 0.5), -1);              // between roots, far from both
  EXPECT_EQ(lines.match(roots, 1.0 + 2.5 * tol), -1);  // 2.5 tol from both neighbours
  EXPECT_EQ(lines.match(roots, -2.0 - 2 * tol), -1);   // before the first
  EXPECT_EQ(lines.match(roots, 10.0), -1);             // after the last
  EXPECT_EQ(lines.match({}, 0.0), -1);                 // an empty line
}

TEST(trace_lines, global_index_numbers_roots_line_by_line) {
  const trace_lines lines(
      {root(0, 0, 1.0), root(0, 0, 2.0), root(0, 1, 5.0), root(1, 0, -1.0), root(1, 0, 0.0), root(1, 0, 1.0)});
  ASSERT_EQ(lines.line_count(), 3u);
  std::uint32_t expected = 0;
  for (std::size_t n = 0; n < lines.line_count(); ++n) {
    for (std::size_t r = 0; r < lines.roots(n).size(); ++r) EXPECT_EQ(lines.global_index(n, r), expected++);
  }
  EXPECT_EQ(expected, lines.root_count());
  EXPECT_EQ(lines.global_index(1, 0), 2u);
  EXPECT_EQ(lines.global_index(2, 2), 5u);
}

TEST(trace_lines, absent_lines_are_not_found_and_hold_no_roots) {
  const trace_lines lines({root(0, 0, 1.0), root(2, 2, 1.0)});
  EXPECT_EQ(lines.find({0, 0}), 0u);
  EXPECT_EQ(lines.find({2, 2}), 1u);
  for (const line_id absent : {line_id{1, 1}, line_id{-1, 0}, line_id{3, 0}, line_id{0, 1}, line_id{2, 3}}) {
    EXPECT_EQ(lines.find(absent), lines.line_count());
    EXPECT_TRUE(lines.roots_of(absent).empty());
  }
  const trace_lines empty;
  EXPECT_EQ(empty.line_count(), 0u);
  EXPECT_EQ(empty.root_count(), 0u);
  EXPECT_EQ(empty.find({0, 0}), 0u);
  EXPECT_TRUE(empty.roots_of({0, 0}).empty());
  EXPECT_TRUE(empty.entries().empty());
}

TEST(trace_lines, entries_rebuild_the_same_lines) {
  const trace_lines lines({root(2, 1, 3.0), root(0, 0, 1.0), root(0, 0, -4.0), root(2, 1, -3.0)});
  const trace_lines rebuilt(lines.entries());
  ASSERT_EQ(rebuilt.line_count(), lines.line_count());
  ASSERT_EQ(rebuilt.root_count(), lines.root_count());
  for (std::size_t n = 0; n < lines.line_count(); ++n) {
    EXPECT_EQ(rebuilt.id(n), lines.id(n));
    ASSERT_EQ(rebuilt.roots(n).size(), lines.roots(n).size());
    for (std::size_t r = 0; r < lines.roots(n).size(); ++r) {
      EXPECT_EQ(rebuilt.roots(n)[r].x, lines.roots(n)[r].x);
      EXPECT_EQ(rebuilt.roots(n)[r].gradient, lines.roots(n)[r].gradient);
    }
  }
}

}  // namespace
}  // namespace tracemesh
