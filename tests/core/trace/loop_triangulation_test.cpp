// Tests of core/trace/loop_triangulation.hpp against independent arithmetic: the shoelace area, hand-computed
// shapes, and brute-force enumeration of every triangulation (every band for annuli) scored by a separate
// implementation of the rules and of the shape measure (Heron's formula instead of a cross product).
#include "core/trace/loop_triangulation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <tuple>

#include "core/analysis/triangle_intersection.hpp"

namespace tracemesh {
namespace {

using triangle_list = std::vector<std::array<std::uint32_t, 3>>;

constexpr std::uint8_t line_jk = wall_y_low | wall_z_low;      // root on line (J, K)
constexpr std::uint8_t line_j1k = wall_y_high | wall_z_low;    // (J+1, K)
constexpr std::uint8_t line_j1k1 = wall_y_high | wall_z_high;  // (J+1, K+1)
constexpr std::uint8_t line_jk1 = wall_y_low | wall_z_high;    // (J, K+1)

loop_vertex vertex(vec3 position, vec3 normal, std::uint8_t planes) {
  return {position, normalized(normal), planes};
}

// ---- Independent scoring (no code shared with the implementation) --------------------------------------------

/// min(shortest/longest, 4√3·area/Σe²) with the area from Heron's formula.
double reference_quality(const vec3& a, const vec3& b, const vec3& c) {
  const double la = distance(b, c), lb = distance(c, a), lc = distance(a, b);
  const double s = (la + lb + lc) / 2;
  const double area = std::sqrt(std::max(0.0, s * (s - la) * (s - lb) * (s - lc)));
  const double ratio = std::min({la, lb, lc}) / std::max({la, lb, lc});
  return std::min(ratio, 4 * std::sqrt(3.0) * area / (la * la + lb * lb + lc * lc));
}

/// Rules 2 and 3 for the ordered triangle a, b, c (as documented, with the default settings).
bool reference_geometry_ok(const loop_vertex& a, const loop_vertex& b, const loop_vertex& c) {
  const loop_triangulation_settings settings;
  const double la = distance(b.position, c.position), lb = distance(c.position, a.position),
               lc = distance(a.position, b.position);
  if (std::min({la, lb, lc}) < settings.min_edge_length) return false;
  const vec3 face = cross(b.position - a.position, c.position - a.position);
  const double longest = std::max({la, lb, lc});
  if (norm(face) / 2 < settings.min_area_ratio * longest * longest) return false;
  const vec3 normals = a.normal + b.normal + c.normal;
  return dot(face, normals) > settings.min_normal_cosine * norm(face) * norm(normals);
}

struct score {
  bool feasible = false;
  double worst = 0, sum = 0;
};

/// Scores a triangle set over `vertices` with `consecutive(u, v)` telling the loop edges: every rule checked.
score reference_score(std::span<const loop_vertex> vertices, const triangle_list& triangles,
                      const std::function<bool(std::uint32_t, std::uint32_t)>& consecutive) {
  score result{true, 1, 0};
  for (const auto& t : triangles) {
    const loop_vertex &a = vertices[t[0]], &b = vertices[t[1]], &c = vertices[t[2]];
    if ((a.planes & b.planes & c.planes) != 0) return {};
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t u = t[e], v = t[(e + 1) % 3];
      if (!consecutive(u, v) && (vertices[u].planes & vertices[v].planes) != 0) return {};
    }
    if (!reference_geometry_ok(a, b, c)) return {};
    const double q = reference_quality(a.position, b.position, c.position);
    result.worst = std::min(result.worst, q);
    result.sum += q;
  }
  return result;
}

std::function<bool(std::uint32_t, std::uint32_t)> loop_adjacency(std::size_t n) {
  return [n](std::uint32_t u, std::uint32_t v) {
    const std::size_t d = u > v ? u - v : v - u;
    return d == 1 || d == n - 1;
  };
}

/// Every triangulation of the convex index polygon 0..n−1 (as (i, k, j), i < k < j), by recursion on the apex of
/// the triangle on edge (i, j): Catalan(n − 2) of them.
std::vector<triangle_list> all_triangulations(std::uint32_t i, std::uint32_t j) {
  if (j - i < 2) return {triangle_list{}};
  std::vector<triangle_list> result;
  for (std::uint32_t k = i + 1; k < j; ++k)
    for (const auto& left : all_triangulations(i, k))
      for (const auto& right : all_triangulations(k, j)) {
        triangle_list t = left;
        t.insert(t.end(), right.begin(), right.end());
        t.push_back({i, k, j});
        result.push_back(std::move(t));
      }
  return result;
}

/// The best over a list of candidate triangulations: the highest worst quality q*, then the highest sum among the
/// candidates whose worst is q* up to a relative 1e-12 (as documented: symmetric triangles differ by rounding).
score brute_force_best(std::span<const loop_vertex> vertices, const std::vector<triangle_list>& candidates,
                       const std::function<bool(std::uint32_t, std::uint32_t)>& consecutive) {
  std::vector<score> scores;
  double optimum = -1;
  for (const auto& c : candidates) {
    scores.push_back(reference_score(vertices, c, consecutive));
    if (scores.back().feasible) optimum = std::max(optimum, scores.back().worst);
  }
  score best;
  for (const score& s : scores)
    if (s.feasible && s.worst >= optimum * (1 - 1e-12) && (!best.feasible || s.sum > best.sum)) best = s;
  if (best.feasible) best.worst = optimum;
  return best;
}

/// Structural checks of a loop triangulation: n − 2 triangles in loop order (i < k < j), each loop edge in exactly
/// one triangle, every other edge in exactly two with opposite directions; all rules hold.
void expect_valid_loop_triangulation(std::span<const loop_vertex> loop, const triangle_list& triangles) {
  const std::size_t n = loop.size();
  ASSERT_EQ(triangles.size(), n - 2);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : triangles) {
    EXPECT_TRUE(t[0] < t[1] && t[1] < t[2]) << "triangle not in loop order";
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1);
    const auto [u, v] = edge;
    const bool loop_edge = v == u + 1 || (u == n - 1 && v == 0) || (u == 0 && v == n - 1) || u == v + 1;
    if (loop_edge)
      EXPECT_EQ(directed.count({v, u}), 0u) << "loop edge used twice";
    else
      EXPECT_EQ(directed.count({v, u}), 1u) << "chord " << u << "-" << v << " not shared by two triangles";
  }
  EXPECT_TRUE(reference_score(loop, triangles, loop_adjacency(n)).feasible) << "a rule is broken";
}

std::set<std::array<std::uint32_t, 3>> as_set(const triangle_list& t) { return {t.begin(), t.end()}; }

// ---- Loops ----------------------------------------------------------------------------------------------------

TEST(LoopTriangulation, PlanarConvexPolygonHasShoelaceArea) {
  // A convex 9-gon in a tilted plane: u, v span the plane, the normal is u × v.
  const vec3 u = normalized({1, 0.3, -0.2}), v = normalized(cross({0.2, 0.4, 1.0}, u));
  const vec3 n = cross(u, v);
  const vec3 origin{3, -1, 2};
  std::vector<std::array<double, 2>> uv;
  for (int i = 0; i < 9; ++i) {
    const double angle = 2 * std::numbers::pi * (i + 0.3 * std::sin(i)) / 9;
    uv.push_back({2.0 * std::cos(angle), 1.3 * std::sin(angle)});
  }
  std::vector<loop_vertex> loop;
  for (const auto& [a, b] : uv) loop.push_back(vertex(origin + a * u + b * v, n, 0));
  double shoelace = 0;
  for (std::size_t i = 0; i < uv.size(); ++i) {
    const auto& p = uv[i];
    const auto& q = uv[(i + 1) % uv.size()];
    shoelace += (p[0] * q[1] - q[0] * p[1]) / 2;
  }
  ASSERT_GT(shoelace, 0);

  triangle_list out;
  const std::optional<double> worst = triangulate_loop(loop, out);
  ASSERT_TRUE(worst);
  expect_valid_loop_triangulation(loop, out);
  double area = 0;
  for (const auto& t : out) {
    const vec3 face = cross(loop[t[1]].position - loop[t[0]].position, loop[t[2]].position - loop[t[0]].position);
    EXPECT_GT(dot(face, n), 0) << "triangle not counter-clockwise";
    area += dot(face, n) / 2;
  }
  EXPECT_NEAR(area, shoelace, 1e-12 * shoelace);
  EXPECT_EQ(out.size(), 7u);
  EXPECT_GT(*worst, 0);
}

TEST(LoopTriangulation, SquareOnCornerLinesTakesTheBetterDiagonal) {
  // Four roots on the corner lines of the cell y, z ∈ [0, 1], on the plane x = α·y + β·z (outward normal towards
  // +x, so counter-clockwise in (y, z) is counter-clockwise seen from outside). Both diagonals are admissible.
  for (const auto& slopes : {std::pair{1.5, 0.5}, std::pair{1.5, -1.0}, std::pair{-0.4, 1.2}}) {
    const double alpha = slopes.first, beta = slopes.second;
    const vec3 normal{1, -alpha, -beta};
    const auto at = [&](double y, double z) { return vec3{alpha * y + beta * z, y, z}; };
    const std::vector<loop_vertex> loop = {vertex(at(0, 0), normal, line_jk), vertex(at(1, 0), normal, line_j1k),
                                           vertex(at(1, 1), normal, line_j1k1), vertex(at(0, 1), normal, line_jk1)};
    // By hand: the worst edge ratio of each choice (these triangles are not obtuse beyond 122°, checked below).
    const auto worst_of = [&](std::array<int, 3> t1, std::array<int, 3> t2) {
      return std::min(reference_quality(loop[t1[0]].position, loop[t1[1]].position, loop[t1[2]].position),
                      reference_quality(loop[t2[0]].position, loop[t2[1]].position, loop[t2[2]].position));
    };
    const double with_02 = worst_of({0, 1, 2}, {0, 2, 3});
    const double with_13 = worst_of({0, 1, 3}, {1, 2, 3});
    ASSERT_GT(std::abs(with_02 - with_13), 0.05);

    triangle_list out;
    const std::optional<double> worst = triangulate_loop(loop, out);
    ASSERT_TRUE(worst);
    expect_valid_loop_triangulation(loop, out);
    const bool chose_02 = as_set(out) == std::set<std::array<std::uint32_t, 3>>{{0, 1, 2}, {0, 2, 3}};
    EXPECT_EQ(chose_02, with_02 > with_13) << "alpha " << alpha << " beta " << beta;
    EXPECT_NEAR(*worst, std::max(with_02, with_13), 1e-12);
  }
  // Independent arithmetic for the first case: x = 1.5y + 0.5z. Diagonal 1–3 = (0,1,0)–(0.5,0,1): |.| = √3;
  // triangle 0,1,3 has edges √3.25, √1.25, √3 → edge ratio √(1.25/3.25) = 0.620; diagonal 0–2 makes triangle
  // 0,1,2 with edges √3.25, √1.25, √6 → 0.456.
  EXPECT_NEAR(std::sqrt(1.25 / 3.25), 0.6202, 1e-4);
}

/// The quarter of the ellipsoid x²/A² + (y + s)² + (z + s)² = 1 (A = 0.3, s = 0.4) in the cell quadrant y, z ≥ 0:
/// the line (J, K) (y = z = 0) pierces it at a and b; the arc in wall y = 0 leaves a and returns to the same line
/// at b through e; the arc in wall z = 0 closes the loop through f. Loop a, e, b, f.
std::vector<loop_vertex> returning_arc_loop(bool with_walls) {
  const double A = 0.3, s = 0.4, rho = std::sqrt(1 - 2 * s * s), h = std::sqrt(1 - s * s) - s;
  const auto normal = [&](vec3 p) { return vec3{p.x / (A * A), p.y + s, p.z + s}; };
  const vec3 a{-A * rho, 0, 0}, e{0, 0, h}, b{A * rho, 0, 0}, f{0, h, 0};
  const auto w = [&](std::uint8_t planes) { return with_walls ? planes : std::uint8_t{0}; };
  return {vertex(a, normal(a), w(line_jk)), vertex(e, normal(e), w(wall_y_low)), vertex(b, normal(b), w(line_jk)),
          vertex(f, normal(f), w(wall_z_low))};
}

TEST(LoopTriangulation, ArcReturningToItsLineAvoidsTheForbiddenTriangle) {
  // Without walls the chord a–b (diagonal 0–2) is the better one, so only the rule can steer away from it.
  const auto free_loop = returning_arc_loop(false);
  const std::set<std::array<std::uint32_t, 3>> via_ab{{0, 1, 2}, {0, 2, 3}}, via_ef{{0, 1, 3}, {1, 2, 3}};
  const auto worst = [&](const std::set<std::array<std::uint32_t, 3>>& t) {
    double w = 1;
    for (const auto& x : t)
      w = std::min(w, reference_quality(free_loop[x[0]].position, free_loop[x[1]].position, free_loop[x[2]].position));
    return w;
  };
  ASSERT_GT(worst(via_ab), worst(via_ef) + 0.05);
  triangle_list out;
  ASSERT_TRUE(triangulate_loop(free_loop, out));
  EXPECT_EQ(as_set(out), via_ab);

  // With walls: (a, e, b) has all three corners on y = y_J, and a–b joins two non-consecutive points of line (J,K).
  const auto loop = returning_arc_loop(true);
  out.clear();
  const std::optional<double> worst_with_walls = triangulate_loop(loop, out);
  ASSERT_TRUE(worst_with_walls);
  expect_valid_loop_triangulation(loop, out);
  EXPECT_EQ(as_set(out), via_ef);
  for (const auto& t : out) EXPECT_FALSE(std::find(t.begin(), t.end(), 0u) != t.end() &&
                                         std::find(t.begin(), t.end(), 2u) != t.end());
  EXPECT_NEAR(*worst_with_walls, worst(via_ef), 1e-12);
}

TEST(LoopTriangulation, ReturnsFalseAndAppendsNothingWhenNoTriangulationIsAdmissible) {
  const triangle_list sentinel = {{7, 8, 9}};
  const auto expect_failure = [&](const std::vector<loop_vertex>& loop, const char* what) {
    triangle_list out = sentinel;
    EXPECT_FALSE(triangulate_loop(loop, out)) << what;
    EXPECT_EQ(out, sentinel) << what;
  };
  // The returning arc a → e → b alone, closed by the chord back along the line: its one triangle lies on y = y_J.
  auto loop = returning_arc_loop(true);
  loop.pop_back();
  expect_failure(loop, "three corners on one wall");
  // Four points of one arc pair that all lie on wall y_low: every chord joins two points of that wall.
  expect_failure({vertex({0, 0, 0}, {0, 1, 0}, line_jk), vertex({1, 0, 0.5}, {0, 1, 0}, wall_y_low),
                  vertex({2, 0, 0}, {0, 1, 0}, line_jk), vertex({1, 0, -0.5}, {0, 1, 0}, wall_y_low)},
                 "every chord on one wall");
  // A planar square whose normals point the wrong way (the loop is clockwise seen from outside).
  std::vector<loop_vertex> square = {vertex({0, 0, 0}, {0, 0, -1}, 0), vertex({1, 0, 0}, {0, 0, -1}, 0),
                                     vertex({1, 1, 0}, {0, 0, -1}, 0), vertex({0, 1, 0}, {0, 0, -1}, 0)};
  expect_failure(square, "orientation");
  // Normals in the plane of the polygon: no face can agree with them by the margin.
  for (auto& v : square) v.normal = {1, 0, 0};
  expect_failure(square, "normals tangent to the faces");
  // A loop edge far below the certificate's margin, and collinear corners.
  expect_failure({vertex({0, 0, 0}, {0, 0, 1}, 0), vertex({1e-8, 0, 0}, {0, 0, 1}, 0),
                  vertex({0, 1, 0}, {0, 0, 1}, 0)},
                 "short edge");
  expect_failure({vertex({0, 0, 0}, {0, 0, 1}, 0), vertex({1, 1e-12, 0}, {0, 0, 1}, 0),
                  vertex({2, 0, 0}, {0, 0, 1}, 0)},
                 "collinear");
  expect_failure({vertex({0, 0, 0}, {0, 0, 1}, 0), vertex({1, 0, 0}, {0, 0, 1}, 0)}, "two vertices");
}

TEST(LoopTriangulation, NegativeNormalCosineRelaxesOrTurnsOffRuleTwo) {
  std::vector<loop_vertex> square = {vertex({0, 0, 0}, {1, 0, 0}, 0), vertex({1, 0, 0}, {1, 0, 0}, 0),
                                     vertex({1, 1.2, 0}, {1, 0, 0}, 0), vertex({0, 1, 0}, {1, 0, 0}, 0)};
  loop_triangulation_settings settings;
  triangle_list out;
  // Normals in the faces' plane: cos = 0.
  EXPECT_FALSE(triangulate_loop(square, out, settings));
  settings.min_normal_cosine = -0.5;
  EXPECT_TRUE(triangulate_loop(square, out, settings));
  // Normals opposite to the faces: cos = −1, refused even with the rule off, whose floor refuses a face against
  // all three corners (a fold).
  for (auto& v : square) v.normal = {0, 0, -1};
  out.clear();
  EXPECT_FALSE(triangulate_loop(square, out, settings));
  settings.min_normal_cosine = -2;
  EXPECT_FALSE(triangulate_loop(square, out, settings));
  // Opposite at three corners but along at vertex 0: with the rule off, the triangulation whose faces both hold
  // vertex 0 (the other one's (1, 2, 3) would be a fold).
  square[0].normal = {0, 0, 1};
  EXPECT_TRUE(triangulate_loop(square, out, settings));
  ASSERT_EQ(out.size(), 2u);
  for (const auto& t : out) EXPECT_TRUE(t[0] == 0 && t[0] < t[1] && t[1] < t[2]);
  // Rule 3 stays on.
  square[1].position = square[0].position + vec3{1e-8, 0, 0};
  out.clear();
  EXPECT_FALSE(triangulate_loop(square, out, settings));
  EXPECT_TRUE(out.empty());
}

/// An n-gon around the cell centre on the saddle x = κ·((y − ½)² − (z − ½)²), radius r, normal towards +x.
std::vector<loop_vertex> saddle_loop(int n, double kappa, double r, double phase) {
  std::vector<loop_vertex> loop;
  for (int i = 0; i < n; ++i) {
    const double angle = phase + 2 * std::numbers::pi * i / n;
    const double y = 0.5 + r * std::cos(angle), z = 0.5 + r * std::sin(angle);
    const double dy = y - 0.5, dz = z - 0.5;
    loop.push_back(vertex({kappa * (dy * dy - dz * dz), y, z}, {1, -2 * kappa * dy, 2 * kappa * dz}, 0));
  }
  return loop;
}

TEST(LoopTriangulation, SaddleLoopMatchesBruteForce) {
  for (const double kappa : {0.5, 2.0, 4.0}) {
    const auto loop = saddle_loop(8, kappa, 0.5, 0.1);
    triangle_list out;
    ASSERT_TRUE(triangulate_loop(loop, out)) << kappa;
    expect_valid_loop_triangulation(loop, out);
    const score mine = reference_score(loop, out, loop_adjacency(loop.size()));
    const score best = brute_force_best(loop, all_triangulations(0, 7), loop_adjacency(loop.size()));
    ASSERT_TRUE(best.feasible);
    EXPECT_NEAR(mine.worst, best.worst, 1e-9) << kappa;
    EXPECT_NEAR(mine.sum, best.sum, 1e-9) << kappa;
    // The saddle bends the faces away from the normals; each still agrees with them (checked by the score).
  }
}

TEST(LoopTriangulation, ReversedLoopWithFlippedNormalsGivesTheSameTriangles) {
  for (const double kappa : {0.5, 3.0}) {
    const auto loop = saddle_loop(7, kappa, 0.5, 0.3);
    std::vector<loop_vertex> reversed(loop.rbegin(), loop.rend());
    for (auto& v : reversed) v.normal = -v.normal;
    triangle_list out, out_reversed;
    ASSERT_TRUE(triangulate_loop(loop, out));
    ASSERT_TRUE(triangulate_loop(reversed, out_reversed));
    expect_valid_loop_triangulation(reversed, out_reversed);
    const auto n = static_cast<std::uint32_t>(loop.size());
    std::set<std::array<std::uint32_t, 3>> mapped;
    for (const auto& t : out_reversed) {
      // Each triangle is counter-clockwise for the flipped normals ...
      const vec3 face = cross(reversed[t[1]].position - reversed[t[0]].position,
                              reversed[t[2]].position - reversed[t[0]].position);
      EXPECT_GT(dot(face, reversed[t[0]].normal + reversed[t[1]].normal + reversed[t[2]].normal), 0);
      // ... and the same triangle as the original's, traversed the other way.
      std::array<std::uint32_t, 3> back = {n - 1 - t[2], n - 1 - t[1], n - 1 - t[0]};
      mapped.insert(back);
    }
    EXPECT_EQ(mapped, as_set(out)) << kappa;
    // The original order with the flipped normals is inconsistent: nothing is admissible.
    std::vector<loop_vertex> flipped = loop;
    for (auto& v : flipped) v.normal = -v.normal;
    triangle_list none;
    EXPECT_FALSE(triangulate_loop(flipped, none));
  }
}

/// A long loop along x: the roof z = s(y)·sin(πx/L), s(y) = 0.5 + 0.1·y, over the cell y ∈ [0, 1] from x = 0 to L,
/// outward normal up. Its boundary: the arc on wall y = 0 leaves line (J,K) at x = 0 and returns to it at x = L;
/// a short arc on z = 0 crosses to line (J+1,K); the arc on y = 1 runs back; a short arc on z = 0 closes it.
std::vector<loop_vertex> roof_loop(int interior, double spacing) {
  const double L = spacing * (interior + 1);
  const auto point = [&](double x, double y) {
    const double s = 0.5 + 0.1 * y, k = std::numbers::pi / L;
    return std::pair{vec3{x, y, s * std::sin(k * x)}, vec3{-s * k * std::cos(k * x), -0.1 * std::sin(k * x), 1}};
  };
  std::vector<loop_vertex> loop;
  const auto add = [&](double x, double y, std::uint8_t planes) {
    const auto [p, n] = point(x, y);
    loop.push_back(vertex(p, n, planes));
  };
  add(0, 0, line_jk);
  for (int i = 1; i <= interior; ++i) add(spacing * i, 0, wall_y_low);
  add(L, 0, line_jk);
  add(L, 1, line_j1k);
  for (int i = interior; i >= 1; --i) add(spacing * i + 0.37 * spacing, 1, wall_y_high);
  add(0, 1, line_j1k);
  return loop;
}

TEST(LoopTriangulation, LongLoopAlongXIsAZigzag) {
  const auto loop = roof_loop(98, 1.0);
  ASSERT_EQ(loop.size(), 200u);
  triangle_list out;
  const std::optional<double> worst = triangulate_loop(loop, out);
  ASSERT_TRUE(worst);
  expect_valid_loop_triangulation(loop, out);
  // Admissibility leaves only zigzags: every triangle has corners on both long walls.
  for (const auto& t : out) {
    const std::uint8_t all = loop[t[0]].planes | loop[t[1]].planes | loop[t[2]].planes;
    EXPECT_TRUE((all & wall_y_low) && (all & wall_y_high));
  }
  // Spacing 1 Å, width 1 Å, the far arc shifted by 0.37: the best zigzag's triangles have edge ratio around
  // 1/√(1 + 0.63²) ≈ 0.85 in the middle; the ends (a 1.37 Å step) bring the worst down but not far.
  EXPECT_GT(*worst, 0.5);
  double quality_sum = 0;
  for (const auto& t : out) {
    quality_sum += triangle_quality(loop[t[0]].position, loop[t[1]].position, loop[t[2]].position);
  }
  EXPECT_GT(quality_sum / static_cast<double>(out.size()), 0.7);
}

TEST(LoopTriangulation, RandomLoopsMatchBruteForce) {
  std::mt19937 rng(2011);
  std::uniform_real_distribution<double> unit(0, 1);
  int feasible = 0, infeasible_count = 0;
  for (int n = 3; n <= 8; ++n) {
    const auto candidates = all_triangulations(0, static_cast<std::uint32_t>(n - 1));
    for (int trial = 0; trial < 150; ++trial) {
      // Convex (trial even) or star-shaped non-planar (odd) polygon, around a random axis; random walls.
      const vec3 axis = normalized({unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5 + 1e-3});
      const vec3 u = normalized(cross(axis, {0.3, 0.9, 0.1}));
      const vec3 v = cross(axis, u);
      std::vector<double> angles;
      for (int i = 0; i < n; ++i) angles.push_back(2 * std::numbers::pi * unit(rng));
      std::sort(angles.begin(), angles.end());
      const bool convex = trial % 2 == 0;
      std::vector<loop_vertex> loop;
      for (int i = 0; i < n; ++i) {
        const double radius = convex ? 1.0 : 0.5 + unit(rng), height = convex ? 0.0 : 0.4 * (unit(rng) - 0.5);
        const vec3 normal = convex ? axis : normalized(axis + 0.3 * (unit(rng) - 0.5) * u + 0.3 * (unit(rng) - 0.5) * v);
        std::uint8_t planes = 0;
        for (int w = 0; w < 4; ++w)
          if (unit(rng) < 0.25) planes |= static_cast<std::uint8_t>(1 << w);
        loop.push_back(vertex(radius * (std::cos(angles[i]) * u + std::sin(angles[i]) * v) + height * axis, normal,
                              planes));
      }
      triangle_list out;
      const std::optional<double> worst = triangulate_loop(loop, out);
      const bool ok = worst.has_value();
      const score best = brute_force_best(loop, candidates, loop_adjacency(loop.size()));
      ASSERT_EQ(ok, best.feasible) << "n " << n << " trial " << trial;
      if (!ok) {
        ++infeasible_count;
        continue;
      }
      ++feasible;
      expect_valid_loop_triangulation(loop, out);
      const score mine = reference_score(loop, out, loop_adjacency(loop.size()));
      EXPECT_NEAR(mine.worst, best.worst, 1e-9) << "n " << n << " trial " << trial;
      EXPECT_NEAR(mine.sum, best.sum, 1e-9) << "n " << n << " trial " << trial;
      EXPECT_NEAR(*worst, best.worst, 1e-9);
    }
  }
  // Both outcomes are exercised.
  EXPECT_GT(feasible, 300);
  EXPECT_GT(infeasible_count, 50);
}

/// The optimum over every triangulation of a loop too long to enumerate, by a plain O(n³) dynamic programme without
/// any pruning, on the reference scoring: best worst quality, then best sum among triangulations reaching it.
score reference_dp(std::span<const loop_vertex> loop) {
  const std::size_t n = loop.size();
  const auto adjacent = loop_adjacency(n);
  const auto chord_ok = [&](std::size_t i, std::size_t j) {
    return adjacent(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j)) ||
           (loop[i].planes & loop[j].planes) == 0;
  };
  const auto q = [&](std::size_t i, std::size_t k, std::size_t j) {
    const loop_vertex &a = loop[i], &b = loop[k], &c = loop[j];
    if ((a.planes & b.planes & c.planes) != 0 || !reference_geometry_ok(a, b, c)) return -1.0;
    return reference_quality(a.position, b.position, c.position);
  };
  std::vector<std::vector<double>> worst(n, std::vector<double>(n, -1)), sum(n, std::vector<double>(n, -1e300));
  for (std::size_t i = 0; i + 1 < n; ++i) worst[i][i + 1] = 2;
  for (std::size_t len = 2; len < n; ++len)
    for (std::size_t i = 0; i + len < n; ++i) {
      const std::size_t j = i + len;
      if (!chord_ok(i, j)) continue;
      for (std::size_t k = i + 1; k < j; ++k)
        worst[i][j] = std::max(worst[i][j], std::min({worst[i][k], worst[k][j], q(i, k, j)}));
    }
  const double optimum = worst[0][n - 1];
  if (optimum < 0) return {};
  const double threshold = optimum * (1 - 1e-12);
  for (std::size_t i = 0; i + 1 < n; ++i) sum[i][i + 1] = 0;
  for (std::size_t len = 2; len < n; ++len)
    for (std::size_t i = 0; i + len < n; ++i) {
      const std::size_t j = i + len;
      if (!chord_ok(i, j)) continue;
      for (std::size_t k = i + 1; k < j; ++k) {
        const double qk = q(i, k, j);
        if (qk >= threshold && sum[i][k] > -1e299 && sum[k][j] > -1e299)
          sum[i][j] = std::max(sum[i][j], qk + sum[i][k] + sum[k][j]);
      }
    }
  return {true, optimum, sum[0][n - 1]};
}

/// A loop around the cell y, z ∈ [0, 1] on the random smooth surface x = f(y, z) (normal towards +x): a root on
/// each corner line and `per_wall[w]` arc points inside each wall, counter-clockwise in (y, z).
std::vector<loop_vertex> random_cell_loop(std::mt19937& rng, std::array<int, 4> per_wall) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double c1 = 2 * unit(rng) - 1, c2 = 2 * unit(rng) - 1, c3 = 2 * unit(rng) - 1, c4 = 2 * unit(rng) - 1;
  std::vector<loop_vertex> loop;
  const auto add = [&](double y, double z, std::uint8_t planes) {
    const double x = c1 * y * y + c2 * z * z + c3 * y * z + c4 * y;
    loop.push_back(vertex({x, y, z}, {1, -(2 * c1 * y + c3 * z + c4), -(2 * c2 * z + c3 * y)}, planes));
  };
  const auto interior = [&](int count) {
    std::vector<double> t;
    for (int i = 0; i < count; ++i) t.push_back(0.05 + 0.9 * unit(rng));
    std::sort(t.begin(), t.end());
    return t;
  };
  add(0, 0, line_jk);
  for (double t : interior(per_wall[0])) add(t, 0, wall_z_low);
  add(1, 0, line_j1k);
  for (double t : interior(per_wall[1])) add(1, t, wall_y_high);
  add(1, 1, line_j1k1);
  for (double t : interior(per_wall[2])) add(1 - t, 1, wall_z_high);
  add(0, 1, line_jk1);
  for (double t : interior(per_wall[3])) add(0, 1 - t, wall_y_low);
  return loop;
}

TEST(LoopTriangulation, RandomLongLoopsMatchAPlainDynamicProgramme) {
  std::mt19937 rng(75);
  std::uniform_int_distribution<int> count(0, 12);
  int compared = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const auto loop = trial < 8 ? roof_loop(4 + 3 * trial, 0.9)
                                : random_cell_loop(rng, {count(rng), count(rng), count(rng), count(rng)});
    triangle_list out;
    const bool ok = triangulate_loop(loop, out).has_value();
    const score best = reference_dp(loop);
    ASSERT_EQ(ok, best.feasible) << "trial " << trial << " n " << loop.size();
    if (!ok) continue;
    ++compared;
    expect_valid_loop_triangulation(loop, out);
    const score mine = reference_score(loop, out, loop_adjacency(loop.size()));
    EXPECT_NEAR(mine.worst, best.worst, 1e-9) << "trial " << trial << " n " << loop.size();
    EXPECT_NEAR(mine.sum, best.sum, 1e-9) << "trial " << trial << " n " << loop.size();
  }
  EXPECT_GT(compared, 30);
}

TEST(LoopTriangulation, TheThreadsWorkspaceIsReusedWithoutChangingAResult) {
  const loop_triangulation_settings settings;
  triangle_list out;
  ASSERT_TRUE(triangulate_loop(roof_loop(20, 0.8), out, settings));
  const triangle_list long_result = out;
  out.clear();
  ASSERT_TRUE(triangulate_loop(saddle_loop(6, 1.0, 0.5, 0), out, settings));
  ASSERT_EQ(out.size(), 4u);
  out.clear();
  // A smaller loop after a larger one and then the larger again: same result from the dirty workspace.
  ASSERT_TRUE(triangulate_loop(roof_loop(20, 0.8), out, settings));
  EXPECT_EQ(out, long_result);
}

TEST(LoopTriangulation, TriangleQualityValues) {
  EXPECT_NEAR(triangle_quality({0, 0, 0}, {1, 0, 0}, {0.5, std::sqrt(3.0) / 2, 0}), 1, 1e-12);
  EXPECT_NEAR(triangle_quality({0, 0, 0}, {1, 0, 0}, {0, 1, 0}), 1 / std::sqrt(2.0), 1e-12);  // edge ratio
  // A flat cap 1, 1, 1.9: edge ratio 0.526 but mean ratio 0.366 decides.
  const double h = std::sqrt(1 - 0.95 * 0.95);
  EXPECT_NEAR(triangle_quality({0, 0, 0}, {1.9, 0, 0}, {0.95, h, 0}),
              4 * std::sqrt(3.0) * (0.95 * h) / (1 + 1 + 1.9 * 1.9), 1e-12);
  EXPECT_EQ(triangle_quality({0, 0, 0}, {0, 0, 0}, {1, 0, 0}), 0);
}

// ---- Annuli ---------------------------------------------------------------------------------------------------

/// A tube: the cylinder of radius R around the x axis between x = 0 and x = len, outward normal radial. The loop at
/// x = 0 runs with increasing angle and the one at x = len with decreasing angle, so that the surface is on the left
/// of both seen from outside.
std::pair<std::vector<loop_vertex>, std::vector<loop_vertex>> tube(int p, int q, double R, double len,
                                                                   double twist) {
  std::vector<loop_vertex> first, second;
  for (int i = 0; i < p; ++i) {
    const double a = 2 * std::numbers::pi * i / p;
    first.push_back(vertex({0, R * std::cos(a), R * std::sin(a)}, {0, std::cos(a), std::sin(a)}, 0));
  }
  for (int i = 0; i < q; ++i) {
    const double a = twist - 2 * std::numbers::pi * i / q;
    second.push_back(vertex({len, R * std::cos(a), R * std::sin(a)}, {0, std::cos(a), std::sin(a)}, 0));
  }
  return {first, second};
}

/// Checks a band over outer ++ inner: p + q triangles, each with corners on both loops, each loop edge once in its
/// loop's direction, every bridge in two triangles with opposite directions, all rules.
void expect_valid_band(std::span<const loop_vertex> outer, std::span<const loop_vertex> inner,
                       const triangle_list& triangles) {
  const std::size_t p = outer.size(), q = inner.size();
  std::vector<loop_vertex> all(outer.begin(), outer.end());
  all.insert(all.end(), inner.begin(), inner.end());
  ASSERT_EQ(triangles.size(), p + q);
  const auto on_outer = [&](std::uint32_t v) { return v < p; };
  const auto consecutive = [&](std::uint32_t u, std::uint32_t v) {
    if (on_outer(u) != on_outer(v)) return false;
    const std::size_t m = on_outer(u) ? p : q;
    const std::size_t d = u > v ? u - v : v - u;
    return d == 1 || d == m - 1;
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : triangles) {
    const int outer_corners = on_outer(t[0]) + on_outer(t[1]) + on_outer(t[2]);
    EXPECT_TRUE(outer_corners == 1 || outer_corners == 2);
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1);
    const auto [u, v] = edge;
    if (consecutive(u, v)) {
      // A loop edge, traversed in its loop's direction.
      const std::size_t m = on_outer(u) ? p : q, base = on_outer(u) ? 0 : p;
      EXPECT_EQ((u - base + 1) % m, v - base) << "loop edge " << u << "-" << v << " reversed";
    } else {
      EXPECT_EQ(directed.count({v, u}), 1u) << "bridge " << u << "-" << v;
    }
  }
  // Euler characteristic of an annulus: V − E + F = 0.
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& [edge, count] : directed) edges.insert(std::minmax(edge.first, edge.second));
  EXPECT_EQ(static_cast<long>(p + q) - static_cast<long>(edges.size()) + static_cast<long>(triangles.size()), 0);
  EXPECT_TRUE(reference_score(all, triangles, consecutive).feasible);
}

/// Every band of two loops, independently: all words of p outer and q inner steps from every start bridge,
/// keeping those whose edges are used at most twice.
score brute_force_band(std::span<const loop_vertex> outer, std::span<const loop_vertex> inner) {
  const auto p = static_cast<std::uint32_t>(outer.size()), q = static_cast<std::uint32_t>(inner.size());
  std::vector<loop_vertex> all(outer.begin(), outer.end());
  all.insert(all.end(), inner.begin(), inner.end());
  const auto consecutive = [&](std::uint32_t u, std::uint32_t v) {
    if ((u < p) != (v < p)) return false;
    const std::uint32_t m = u < p ? p : q, d = u > v ? u - v : v - u;
    return d == 1 || d == m - 1;
  };
  std::vector<triangle_list> candidates;
  for (std::uint32_t word = 0; word < (1u << (p + q)); ++word) {
    if (static_cast<std::uint32_t>(std::popcount(word)) != p) continue;
    for (std::uint32_t a0 = 0; a0 < p; ++a0)
      for (std::uint32_t b0 = 0; b0 < q; ++b0) {
        triangle_list t;
        std::uint32_t a = a0, b = b0;  // outer forwards, inner backwards
        for (std::uint32_t s = 0; s < p + q; ++s) {
          if (word >> s & 1) {
            t.push_back({a, (a + 1) % p, p + b});
            a = (a + 1) % p;
          } else {
            const std::uint32_t b1 = (b + q - 1) % q;
            t.push_back({p + b1, p + b, a});
            b = b1;
          }
        }
        std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
        bool ok = true;
        for (const auto& x : t)
          for (int e = 0; e < 3; ++e) ok = ok && ++uses[std::minmax(x[e], x[(e + 1) % 3])] <= 2;
        if (ok) candidates.push_back(t);
      }
  }
  return brute_force_best(all, candidates, consecutive);
}

TEST(LoopTriangulationAnnulus, TubeBandIsValidAndOptimal) {
  for (const auto& [p, q, twist] : {std::tuple{4, 4, 0.3}, std::tuple{5, 3, 0.1}, std::tuple{3, 6, 1.0},
                                   std::tuple{6, 5, 2.0}, std::tuple{6, 6, 0.0}}) {
    const auto [outer, inner] = tube(p, q, 0.6, 0.9, twist);
    triangle_list out;
    const std::optional<double> worst = triangulate_annulus(outer, inner, out);
    ASSERT_TRUE(worst) << p << " " << q;
    expect_valid_band(outer, inner, out);
    std::vector<loop_vertex> all(outer.begin(), outer.end());
    all.insert(all.end(), inner.begin(), inner.end());
    const auto pp = static_cast<std::uint32_t>(p), qq = static_cast<std::uint32_t>(q);
    const auto consecutive = [&](std::uint32_t u, std::uint32_t v) {
      if ((u < pp) != (v < pp)) return false;
      const std::uint32_t m = u < pp ? pp : qq, d = u > v ? u - v : v - u;
      return d == 1 || d == m - 1;
    };
    const score mine = reference_score(all, out, consecutive);
    const score best = brute_force_band(outer, inner);
    ASSERT_TRUE(best.feasible);
    EXPECT_NEAR(mine.worst, best.worst, 1e-9) << p << " " << q;
    EXPECT_NEAR(mine.sum, best.sum, 1e-9) << p << " " << q;
    EXPECT_NEAR(*worst, best.worst, 1e-9);
  }
}

TEST(LoopTriangulationAnnulus, RandomBandsMatchBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  int feasible = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int p = 3 + trial % 4, q = 3 + (trial / 4) % 3;
    auto [outer, inner] = tube(p, q, 0.5 + 0.3 * unit(rng), 0.3 + unit(rng), 2 * std::numbers::pi * unit(rng));
    for (auto* loop : {&outer, &inner})
      for (auto& v : *loop) {
        v.position += vec3{0.2 * (unit(rng) - 0.5), 0.1 * (unit(rng) - 0.5), 0.1 * (unit(rng) - 0.5)};
        if (unit(rng) < 0.3) v.planes = static_cast<std::uint8_t>(1u << static_cast<int>(4 * unit(rng)));
      }
    triangle_list out;
    const bool ok = triangulate_annulus(outer, inner, out).has_value();
    const score best = brute_force_band(outer, inner);
    ASSERT_EQ(ok, best.feasible) << "trial " << trial;
    if (!ok) continue;
    ++feasible;
    expect_valid_band(outer, inner, out);
    std::vector<loop_vertex> all(outer.begin(), outer.end());
    all.insert(all.end(), inner.begin(), inner.end());
    const auto pp = static_cast<std::uint32_t>(p), qq = static_cast<std::uint32_t>(q);
    const auto consecutive = [&](std::uint32_t u, std::uint32_t v) {
      if ((u < pp) != (v < pp)) return false;
      const std::uint32_t m = u < pp ? pp : qq, d = u > v ? u - v : v - u;
      return d == 1 || d == m - 1;
    };
    const score mine = reference_score(all, out, consecutive);
    EXPECT_NEAR(mine.worst, best.worst, 1e-9) << "trial " << trial;
    EXPECT_NEAR(mine.sum, best.sum, 1e-9) << "trial " << trial;
  }
  EXPECT_GT(feasible, 20);
}

TEST(LoopTriangulationAnnulus, FailsWhenBothLoopsLieOnOneWall) {
  auto [outer, inner] = tube(4, 5, 0.6, 0.9, 0.2);
  for (auto& v : outer) v.planes = wall_y_low;
  for (auto& v : inner) v.planes = wall_y_low | wall_z_high;
  const triangle_list sentinel = {{1, 2, 3}};
  triangle_list out = sentinel;
  EXPECT_FALSE(triangulate_annulus(outer, inner, out));
  EXPECT_EQ(out, sentinel);
  // Same tube, inner loop reversed (both loops the same sense around the axis): the bands fold, orientation fails.
  for (auto& v : outer) v.planes = 0;
  for (auto& v : inner) v.planes = 0;
  std::reverse(inner.begin(), inner.end());
  EXPECT_FALSE(triangulate_annulus(outer, inner, out));
  EXPECT_EQ(out, sentinel);
}

// ---- triangulate_loop_in_its_plane -----------------------------------------------------------------------------

/// Newell's normal of a loop (twice its vector area), and the loop's triangles' total unsigned area and the loop's
/// area, both projected along it: equal exactly when the projected triangles do not overlap.
struct projected_areas {
  double triangles = 0, loop = 0;
};
projected_areas areas_along_newell_normal(const std::vector<loop_vertex>& loop, const triangle_list& triangles) {
  vec3 newell;
  for (std::size_t i = 0; i < loop.size(); ++i) newell += cross(loop[i].position, loop[(i + 1) % loop.size()].position);
  const vec3 n = normalized(newell);
  projected_areas out;
  out.loop = 0.5 * norm(newell);
  for (const auto& t : triangles) {
    out.triangles += 0.5 * std::abs(dot(cross(loop[t[1]].position - loop[t[0]].position,
                                              loop[t[2]].position - loop[t[0]].position), n));
  }
  return out;
}

std::size_t self_intersecting_pairs(const std::vector<loop_vertex>& loop, const triangle_list& triangles) {
  std::vector<vec3> positions;
  for (const loop_vertex& v : loop) positions.push_back(v.position);
  std::size_t pairs = 0;
  for (std::size_t a = 0; a < triangles.size(); ++a) {
    for (std::size_t b = a + 1; b < triangles.size(); ++b) {
      pairs += detail::mesh_triangles_intersect(positions, triangles[a], triangles[b]);
    }
  }
  return pairs;
}

// A loop of mache at d = −15, t0 = 1, 1 v/Å² (cell j = 22, k = −1 of the first line grid, 11 vertices as traced):
// where the contour passes a pinch, the loop doubles back on itself along the wall z = 0. Every triangulation the
// dynamic programme finds, with or without its rules on walls and normals, folds over itself or fails, so the cell
// stayed open. Cut into ears in its own plane, it is not.
std::vector<loop_vertex> doubled_back_loop() {
  return {
      vertex({-19.165821624136196, 23, -1}, {-0.65615220621501902, 0.68256578947368451, 0.32182017543859637}, 6),
      vertex({-19.678497658742593, 22, -1}, {-0.93722448312136031, 0.13432083349798174, 0.32182010802046956}, 5),
      vertex({-18.835431766629259, 22, 0}, {-0.48310760855169588, 0.12855002344468566, 0.86607270481861509}, 9),
      vertex({-18.368704635506383, 22.778433382310613, 0},
             {-0.41866070084452817, 0.5985947324083678, 0.68294038092744436}, 8),
      vertex({-17.497208961227443, 22.790922385780398, 0},
             {0.37505814638631174, 0.60004734602845078, 0.70659363806467756}, 8),
      vertex({-17.092277634525043, 22, 0}, {0.52784079985707466, 0.098577840699751326, 0.8436032831427448}, 9),
      vertex({-16.505826648849808, 22, -0.40920363891996298},
             {-0.0054974138388249293, -0.93599103184661814, 0.35198091815294147}, 1),
      vertex({-16.138073235970719, 22, 0}, {-0.2902952597282466, -0.9064995041417051, 0.3065735004369301}, 9),
      vertex({-16.924738231810444, 22.329665183743167, 0},
             {-0.54674871391834523, -0.75138232959361329, 0.36944612408727506}, 8),
      vertex({-17.434174203054987, 23, 0}, {-0.88060178589974125, -0.34683543879035944, 0.32287098517718366}, 10),
      vertex({-18.369144551432861, 23, -0.26101814075209118},
             {-0.35747470280399962, 0.77089075221286574, 0.52719947364149966}, 2)};
}

TEST(LoopTriangulationInItsPlane, ALoopThatEveryOtherTriangulationFoldsIsCutWithoutOverlap) {
  const std::vector<loop_vertex> loop = doubled_back_loop();
  // The dynamic programme's fallbacks of cell_polygons.cpp: relaxed, flattest, and without the wall rule.
  int triangulated = 0;
  for (int fallback = 0; fallback < 4; ++fallback) {
    std::vector<loop_vertex> vertices = loop;
    loop_triangulation_settings settings;
    if (fallback >= 1) settings.min_normal_cosine = -2;
    settings.maximise_normal_agreement = fallback == 2;
    if (fallback == 3) {
      for (loop_vertex& v : vertices) v.planes = 0;
    }
    triangle_list triangles;
    if (triangulate_loop(vertices, triangles, settings)) {
      ++triangulated;
      EXPECT_GT(self_intersecting_pairs(loop, triangles), 0u) << "fallback " << fallback;
    }
  }
  EXPECT_GT(triangulated, 0);  // they do triangulate it, only folded
  triangle_list out;
  ASSERT_TRUE(triangulate_loop_in_its_plane(loop, out));
  ASSERT_EQ(out.size(), loop.size() - 2);
  EXPECT_EQ(self_intersecting_pairs(loop, out), 0u);
  const projected_areas areas = areas_along_newell_normal(loop, out);
  EXPECT_NEAR(areas.triangles, areas.loop, 1e-12 * areas.loop);  // no projected overlap
  for (const auto& t : out) {
    EXPECT_GT(triangle_quality(loop[t[0]].position, loop[t[1]].position, loop[t[2]].position), 0.0);
  }
  // Every loop edge is used once, each in the loop's direction (the triangles are oriented like the loop).
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : out) {
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  }
  for (std::uint32_t i = 0; i < loop.size(); ++i) {
    const auto next = static_cast<std::uint32_t>((i + 1) % loop.size());
    EXPECT_EQ((directed[{i, next}]), 1) << i;
    EXPECT_EQ((directed[{next, i}]), 0) << i;
  }
}

TEST(LoopTriangulationInItsPlane, ConvexPolygonGetsItsShoelaceArea) {
  std::vector<loop_vertex> loop;
  for (int i = 0; i < 7; ++i) {
    const double angle = 2 * std::numbers::pi * i / 7;
    loop.push_back(vertex({std::cos(angle), std::sin(angle), 0.3}, {0, 0, 1}, 0));
  }
  triangle_list out;
  ASSERT_TRUE(triangulate_loop_in_its_plane(loop, out));
  EXPECT_EQ(out.size(), 5u);
  const double shoelace = 3.5 * std::sin(2 * std::numbers::pi / 7);  // 7 isosceles triangles of the unit circle
  EXPECT_NEAR(areas_along_newell_normal(loop, out).triangles, shoelace, 1e-12);
}

TEST(LoopTriangulationInItsPlane, ALoopWhoseProjectionCrossesItselfIsRefused) {
  // A figure eight in the plane z = 0: its edges (0, 1) and (2, 3) cross.
  const std::vector<loop_vertex> loop = {vertex({0, 0, 0}, {0, 0, 1}, 0), vertex({1, 1, 0}, {0, 0, 1}, 0),
                                         vertex({1, 0, 0}, {0, 0, 1}, 0), vertex({0, 1, 0}, {0, 0, 1}, 0)};
  const triangle_list sentinel = {{7, 8, 9}};
  triangle_list out = sentinel;
  EXPECT_FALSE(triangulate_loop_in_its_plane(loop, out));
  EXPECT_EQ(out, sentinel);
}

}  // namespace
}  // namespace tracemesh
