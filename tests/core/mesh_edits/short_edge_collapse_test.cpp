// Collapsing short edges (core/mesh_edits/short_edge_collapse.hpp) on small closed meshes whose result is known: a
// bipyramid with one edge split next to its end collapses back into the bipyramid; vertices before the first
// movable one (the raw trace mesh's line roots), longer edges and collapses that would pinch the surface are left
// alone.
#include "core/mesh_edits/short_edge_collapse.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "support/mesh_expectations.hpp"

namespace tracemesh {
namespace {

using triangle = std::array<std::uint32_t, 3>;

/// A closed bipyramid over a regular n-gon, counter-clockwise from outside: equator vertices 0 … n − 1 on the unit
/// circle, n the top (0, 0, 1), n + 1 the bottom.
surface_mesh bipyramid(std::uint32_t n = 10) {
  surface_mesh m;
  for (std::uint32_t k = 0; k < n; ++k) {
    const double angle = 2 * std::numbers::pi * k / n;
    m.positions.push_back({std::cos(angle), std::sin(angle), 0});
  }
  m.positions.push_back({0, 0, 1});
  m.positions.push_back({0, 0, -1});
  for (std::uint32_t k = 0; k < n; ++k) {
    m.triangles.push_back({k, (k + 1) % n, n});
    m.triangles.push_back({(k + 1) % n, k, n + 1});
  }
  m.normals = m.positions;
  return m;
}

/// The bipyramid with its equator edge (0, 1) split at `gap` Å from vertex 0 by vertex n + 2: edge (0, n + 2) is
/// `gap` long and its triangles' third corners are the top and the bottom.
surface_mesh bipyramid_with_split_edge(double gap, std::uint32_t n = 10) {
  surface_mesh m = bipyramid(n);
  const std::uint32_t split = n + 2;
  m.positions.push_back(m.positions[0] + normalized(m.positions[1] - m.positions[0]) * gap);
  m.normals.push_back(m.positions.back());
  m.triangles[0] = {0, split, n};
  m.triangles.push_back({split, 1, n});
  m.triangles[1] = {1, split, n + 1};
  m.triangles.push_back({split, 0, n + 1});
  return m;
}

/// The mesh with vertex v renumbered to order[v].
surface_mesh renumbered(const surface_mesh& m, const std::vector<std::uint32_t>& order) {
  surface_mesh out = m;
  for (std::size_t v = 0; v < order.size(); ++v) {
    out.positions[order[v]] = m.positions[v];
    out.normals[order[v]] = m.normals[v];
  }
  for (triangle& t : out.triangles) {
    for (std::uint32_t& v : t) v = order[v];
  }
  return out;
}

/// Each triangle rotated so that its smallest index comes first, sorted: equal for the same oriented triangles.
std::vector<triangle> canonical(std::vector<triangle> triangles) {
  for (triangle& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(triangles.begin(), triangles.end());
  return triangles;
}

void expect_closed_oriented_manifold(const surface_mesh& m) { testing::expect_certified_report(analyze_mesh(m)); }

/// Appends `piece` moved by `shift` to `mesh`: its own vertices, normals and triangles.
void append(surface_mesh& mesh, const surface_mesh& piece, const vec3& shift) {
  const auto first = static_cast<std::uint32_t>(mesh.positions.size());
  for (std::size_t v = 0; v < piece.positions.size(); ++v) {
    mesh.positions.push_back(piece.positions[v] + shift);
    mesh.normals.push_back(piece.normals[v]);
  }
  for (const triangle& t : piece.triangles) mesh.triangles.push_back({first + t[0], first + t[1], first + t[2]});
}

/// A closed tetrahedron 0.02 Å across about the origin, counter-clockwise from outside.
surface_mesh small_tetrahedron() {
  surface_mesh m;
  for (const vec3& corner : {vec3{0.01, 0.01, 0.01}, vec3{0.01, -0.01, -0.01}, vec3{-0.01, 0.01, -0.01},
                             vec3{-0.01, -0.01, 0.01}}) {
    m.positions.push_back(corner);
    m.normals.push_back(normalized(corner));
  }
  m.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  return m;
}

/// bipyramid_with_split_edge(0.25) scaled to radius 10, its split vertex 12 pushed 0.2 Å outwards (a bulge over
/// triangle (0, 1, top)).
surface_mesh bulged_bipyramid() {
  surface_mesh m = bipyramid_with_split_edge(0.25);
  for (vec3& p : m.positions) p = p * 10;
  const vec3 edge_start = m.positions[0], edge_end = m.positions[1];
  m.positions[12] = edge_start + normalized(edge_end - edge_start) * 0.25 + normalized(edge_start + edge_end) * 0.2;
  return m;
}

/// Where a small tetrahedron lies under the bulge of bulged_bipyramid(): the centroid of triangle (0, 1, top).
vec3 under_the_bulge(const surface_mesh& bulged) {
  return (bulged.positions[0] + bulged.positions[1] + bulged.positions[10]) / 3;
}

TEST(short_edge_collapse, a_hair_short_edge_collapses_back_into_the_closed_mesh) {
  surface_mesh m = bipyramid_with_split_edge(1e-4);
  expect_closed_oriented_manifold(m);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2), 1u);
  const surface_mesh expected = bipyramid();
  EXPECT_EQ(m.positions, expected.positions);  // the lower-numbered end stays where it was
  EXPECT_EQ(m.normals, expected.normals);
  EXPECT_EQ(canonical(m.triangles), canonical(expected.triangles));
  expect_closed_oriented_manifold(m);
}

TEST(short_edge_collapse, the_other_vertices_keep_their_order) {
  // Numbered in the order e1, e2, e0, split, e3 … e9, top, bottom: the split vertex (3) is the higher-numbered end
  // and goes; the ten after it move down by one.
  const std::vector<std::uint32_t> sequence{1, 2, 0, 12, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  std::vector<std::uint32_t> order(sequence.size());
  for (std::uint32_t position = 0; position < sequence.size(); ++position) order[sequence[position]] = position;
  surface_mesh m = renumbered(bipyramid_with_split_edge(1e-4), order);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2), 1u);
  std::vector<std::uint32_t> after(12);  // bipyramid vertex v is now after[v]
  for (std::uint32_t position = 0, kept = 0; position < sequence.size(); ++position) {
    if (sequence[position] != 12) after[sequence[position]] = kept++;
  }
  const surface_mesh expected = renumbered(bipyramid(), after);
  EXPECT_EQ(m.positions, expected.positions);
  EXPECT_EQ(canonical(m.triangles), canonical(expected.triangles));
  expect_closed_oriented_manifold(m);
}

TEST(short_edge_collapse, a_short_edge_that_a_collapse_makes_is_collapsed_in_turn) {
  // Edge (0, 1) split at 1e-4 Å from vertex 0 (vertex 12) and again at 2.5e-4 Å (vertex 13): the shortest edge,
  // (0, 12), goes first, and collapsing 12 onto 0 joins 0 to 13, 2.5e-4 Å away, an edge the first pass did not list
  // (its own (12, 13) went with 12). The pass after it collapses that edge too, and the bipyramid is back (the
  // 1k4r_capsid case of short_edge_collapse.cpp).
  surface_mesh m = bipyramid_with_split_edge(1e-4);
  const std::uint32_t top = 10, bottom = 11, first_split = 12, second_split = 13;
  m.positions.push_back(m.positions[0] + normalized(m.positions[1] - m.positions[0]) * 2.5e-4);
  m.normals.push_back(m.positions.back());
  // Triangles (12, 1, top) and (1, 12, bottom) become (12, 13, top), (13, 1, top), (13, 12, bottom), (1, 13, bottom).
  for (triangle& t : m.triangles) {
    if (t == triangle{first_split, 1, top}) t = {first_split, second_split, top};
    if (t == triangle{1, first_split, bottom}) t = {second_split, first_split, bottom};
  }
  m.triangles.push_back({second_split, 1, top});
  m.triangles.push_back({1, second_split, bottom});
  expect_closed_oriented_manifold(m);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-3), 2u);
  const surface_mesh expected = bipyramid();
  EXPECT_EQ(m.positions, expected.positions);
  EXPECT_EQ(canonical(m.triangles), canonical(expected.triangles));
  expect_closed_oriented_manifold(m);
}

// Vertices before the first movable one are the raw trace mesh's line roots: an edge between two of them stays, and
// an edge from one of them to a movable vertex loses the movable end.
TEST(short_edge_collapse, a_vertex_before_the_first_movable_one_is_never_removed) {
  surface_mesh m = bipyramid_with_split_edge(1e-4);  // the short edge joins vertices 0 and 12
  const surface_mesh before = m;
  EXPECT_EQ(collapse_short_edges(m, 13, 1e-2), 0u);  // neither end movable
  EXPECT_EQ(m.positions, before.positions);
  EXPECT_EQ(m.triangles, before.triangles);

  EXPECT_EQ(collapse_short_edges(m, 1, 1e-2), 1u);  // vertex 12 movable, vertex 0 not
  const surface_mesh expected = bipyramid();
  EXPECT_EQ(m.positions, expected.positions) << "vertex 0 stays where it was";
  EXPECT_EQ(canonical(m.triangles), canonical(expected.triangles));
  expect_closed_oriented_manifold(m);
}

TEST(short_edge_collapse, an_edge_at_or_over_the_length_is_kept) {
  surface_mesh m = bipyramid_with_split_edge(2e-2);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2), 0u);
  EXPECT_EQ(m.positions.size(), 13u);
  EXPECT_EQ(m.triangles.size(), 22u);
}

TEST(short_edge_collapse, a_tiny_component_is_left_to_the_quality_pass) {
  // The split octahedron of 7 vertices (a bipyramid over a square): a tiny cavity is the quality pass's to make
  // again whole (remesh_small_components.hpp).
  surface_mesh m = bipyramid_with_split_edge(1e-4, 4);
  expect_closed_oriented_manifold(m);
  const surface_mesh before = m;
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2), 0u);
  EXPECT_EQ(m.triangles, before.triangles);
}

TEST(short_edge_collapse, a_tiny_component_loses_its_short_edge_when_it_may_go_down_to_a_tetrahedron) {
  // The quality pass's last collapses (after the cavities it could remake): the split octahedron becomes the
  // octahedron; a tetrahedron is never collapsed.
  surface_mesh m = bipyramid_with_split_edge(1e-4, 4);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2, 4), 1u);
  const surface_mesh expected = bipyramid(4);
  EXPECT_EQ(m.positions, expected.positions);
  EXPECT_EQ(canonical(m.triangles), canonical(expected.triangles));
  expect_closed_oriented_manifold(m);
  surface_mesh tetrahedron;
  tetrahedron.positions = {{0, 0, 0}, {1e-3, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  tetrahedron.normals = tetrahedron.positions;
  tetrahedron.triangles = {triangle{0, 2, 1}, triangle{0, 1, 3}, triangle{0, 3, 2}, triangle{1, 2, 3}};
  expect_closed_oriented_manifold(tetrahedron);
  EXPECT_EQ(collapse_short_edges(tetrahedron, 0, 1e-2, 4), 0u);
  EXPECT_EQ(collapse_short_edges(tetrahedron, 0, 1e-2, 0), 0u) << "4 vertices at least, whatever is asked";
}

TEST(short_edge_collapse, a_vertex_of_three_triangles_next_to_a_corner_collapses_away) {
  // Vertex 12 inside triangle (0, 1, top), 1e-4 Å from vertex 0 and joined to the three corners: collapsing edge
  // (0, 12) gives back the bipyramid.
  surface_mesh m = bipyramid(10);
  const std::uint32_t top = 10, inside = 12;
  m.positions.push_back(m.positions[0] + normalized(m.positions[1] + m.positions[top] - 2 * m.positions[0]) * 1e-4);
  m.normals.push_back(normalized(m.positions.back()));
  m.triangles[0] = {0, 1, inside};
  m.triangles.push_back({1, top, inside});
  m.triangles.push_back({top, 0, inside});
  expect_closed_oriented_manifold(m);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2), 1u);
  EXPECT_EQ(canonical(m.triangles), canonical(bipyramid(10).triangles));
  expect_closed_oriented_manifold(m);
}

/// The split bipyramid with triangle (0, 12, top) split in three at its centroid by vertex 13: edge (0, 12) has 13
/// (three triangles) as a third corner, and 0 and 12 share three neighbours (13, top, bottom).
surface_mesh bipyramid_with_a_corner_of_three_triangles() {
  surface_mesh m = bipyramid_with_split_edge(1e-4);
  const std::uint32_t top = 10, split = 12, centroid = 13;
  m.positions.push_back((m.positions[0] + m.positions[split] + m.positions[top]) / 3);
  m.normals.push_back(normalized(m.positions.back()));
  m.triangles[0] = {0, split, centroid};
  m.triangles.push_back({split, top, centroid});
  m.triangles.push_back({top, 0, centroid});
  return m;
}

TEST(short_edge_collapse, a_corner_of_three_triangles_beside_the_edge_is_merged_first) {
  // Collapsing (0, 12) alone would leave 13 two triangles on the same three vertices: 13 is merged into 0 or 12
  // (its three triangles become one), then the edge collapses, and the bipyramid is back.
  surface_mesh m = bipyramid_with_a_corner_of_three_triangles();
  expect_closed_oriented_manifold(m);
  EXPECT_EQ(collapse_short_edges(m, 0, 1e-2), 2u);
  expect_closed_oriented_manifold(m);
  EXPECT_EQ(m.positions.size(), 12u);
  EXPECT_EQ(m.triangles.size(), 20u);
}

TEST(short_edge_collapse, a_collapse_that_would_pinch_the_surface_is_refused_when_the_corner_may_not_move) {
  // The same mesh with the corner of three triangles numbered first, below the first movable vertex.
  const surface_mesh split = bipyramid_with_a_corner_of_three_triangles();
  surface_mesh m;
  const auto last = static_cast<std::uint32_t>(split.positions.size() - 1);
  m.positions.push_back(split.positions[last]);
  m.normals.push_back(split.normals[last]);
  for (std::uint32_t v = 0; v < last; ++v) {
    m.positions.push_back(split.positions[v]);
    m.normals.push_back(split.normals[v]);
  }
  for (auto t : split.triangles) {
    for (std::uint32_t& v : t) v = v == last ? 0 : v + 1;
    m.triangles.push_back(t);
  }
  expect_closed_oriented_manifold(m);
  const surface_mesh before = m;
  EXPECT_EQ(collapse_short_edges(m, 1, 1e-2), 0u);
  EXPECT_EQ(m.triangles, before.triangles);
}

/// Triangle (12, 1, top) has normal (1 − p₁₂) × (top − 1): it changes sign as vertex 12 crosses the line through 1
/// and the top. With 12 and 0 3 mÅ either side of that line's midpoint (6 mÅ apart), collapsing 12 onto 0 would turn
/// it over.
surface_mesh bipyramid_whose_split_vertex_may_not_go_onto_vertex_0() {
  surface_mesh m = bipyramid_with_split_edge(1e-4);
  const vec3 midpoint = (m.positions[1] + m.positions[10]) * 0.5;
  m.positions[12] = midpoint + vec3{3e-3, 0, 0};
  m.positions[0] = midpoint - vec3{3e-3, 0, 0};
  return m;
}

TEST(short_edge_collapse, a_collapse_that_would_turn_a_triangle_over_is_refused) {
  surface_mesh m = bipyramid_whose_split_vertex_may_not_go_onto_vertex_0();
  const surface_mesh before = m;
  EXPECT_EQ(collapse_short_edges(m, 1, 1e-2), 0u);  // vertex 0 may not move
  EXPECT_EQ(m.triangles, before.triangles);
  EXPECT_EQ(m.positions, before.positions);
}

// The mirror image: vertex 12 on the wrong side of the line through 1 and the top, so that triangle (12, 1, top)
// faces against the vertex normals (the outward directions of the bipyramid's vertices); collapsing 12 onto 0, on
// the right side, turns that triangle over and puts it right. Without the normals the collapse is refused, as above.
TEST(short_edge_collapse, a_collapse_that_turns_a_triangle_facing_against_the_normals_right_is_made) {
  surface_mesh m = bipyramid_with_split_edge(1e-4);
  const vec3 midpoint = (m.positions[1] + m.positions[10]) * 0.5;
  m.positions[12] = midpoint - vec3{3e-3, 0, 0};
  m.positions[0] = midpoint + vec3{3e-3, 0, 0};
  const auto faces_along_the_normals = [](const surface_mesh& mesh, const triangle& t) {
    const vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    return dot(cross(b - a, c - a), mesh.normals[t[0]] + mesh.normals[t[1]] + mesh.normals[t[2]]) > 0;
  };
  ASSERT_FALSE(faces_along_the_normals(m, {12, 1, 10}));
  surface_mesh without_normals = m;
  without_normals.normals.clear();
  EXPECT_EQ(collapse_short_edges(without_normals, 1, 1e-2), 0u);
  EXPECT_EQ(collapse_short_edges(m, 1, 1e-2), 1u);
  ASSERT_EQ(m.positions.size(), 12u);
  for (const triangle& t : m.triangles) EXPECT_TRUE(faces_along_the_normals(m, t)) << t[0] << " " << t[1] << " " << t[2];
}

// A collapse that turns a triangle by less than a right angle may still leave it facing against the normals at all
// three corners (a fold, which the certificate refuses): here the normals of 0, 1 and the top point inwards, so the
// two triangles (0, 12, top) and (12, 1, top) each face along one corner's normal, and collapsing 12 onto 0 would
// make (0, 1, top), against all three. The raw trace mesh's collapses made most of its folds this way.
TEST(short_edge_collapse, a_collapse_that_would_fold_a_triangle_against_the_normals_is_refused) {
  surface_mesh m = bipyramid_with_split_edge(1e-2);
  for (const std::uint32_t v : {0u, 1u, 10u}) m.normals[v] = -1.0 * m.normals[v];
  ASSERT_EQ(analyze_mesh(m).folded_triangles, 0u);
  const surface_mesh before = m;
  EXPECT_EQ(collapse_short_edges(m, 1, 2e-2), 0u);
  EXPECT_EQ(m.triangles, before.triangles);
  EXPECT_EQ(analyze_mesh(m).folded_triangles, 0u);
}

/// A closed slab: a top at z = 0 over a copy of it at z = −1 (its triangles reversed), joined by sides. On the top,
/// the short edge (a, b) = (0, 1), 0.05 Å long: b's triangle (b, s, r) is a sliver whose line s–r passes between a
/// and b, so b may not go onto a (it would turn over), while a may go onto b.
/// Top: 0 a (0, 0), 1 b (0.05, 0), 2 c (0, 0.6), 3 d (0.03, −0.6), 4 t (0.7, −0.2), 5 s (0.575, 0.6), 6 r (0.3, 0.3),
/// 7 e (−0.6, 0.3), 8 f (−0.6, −0.4); the bottom's vertices are numbered 9 on.
surface_mesh slab_whose_short_edge_keeps_its_higher_end() {
  const std::vector<vec3> top{{0, 0, 0},      {0.05, 0, 0},  {0, 0.6, 0},  {0.03, -0.6, 0},  {0.7, -0.2, 0},
                              {0.575, 0.6, 0}, {0.3, 0.3, 0}, {-0.6, 0.3, 0}, {-0.6, -0.4, 0}};
  const std::uint32_t a = 0, b = 1, c = 2, d = 3, t = 4, s = 5, r = 6, e = 7, f = 8, n = 9;
  const std::vector<triangle> top_triangles{{b, d, t}, {b, t, s}, {b, s, r}, {b, r, c}, {b, c, a},
                                            {b, a, d}, {a, c, e}, {a, e, f}, {a, f, d}};
  const std::vector<std::uint32_t> boundary{d, t, s, r, c, e, f};  // counter-clockwise seen from above
  surface_mesh m;
  for (const vec3& p : top) {
    m.positions.push_back(p);
    m.normals.push_back({0, 0, 1});
  }
  for (const vec3& p : top) {
    m.positions.push_back(p + vec3{0, 0, -1});
    m.normals.push_back({0, 0, -1});
  }
  for (const triangle& tri : top_triangles) {
    m.triangles.push_back(tri);
    m.triangles.push_back({tri[0] + n, tri[2] + n, tri[1] + n});
  }
  for (std::size_t i = 0; i < boundary.size(); ++i) {
    const std::uint32_t p = boundary[i], q = boundary[(i + 1) % boundary.size()];
    m.triangles.push_back({q, p, p + n});
    m.triangles.push_back({q, p + n, q + n});
  }
  return m;
}

TEST(short_edge_collapse, where_the_lower_end_may_not_be_kept_the_other_is_when_both_may_move) {
  surface_mesh m = slab_whose_short_edge_keeps_its_higher_end();
  const surface_mesh before = m;
  expect_closed_oriented_manifold(m);

  EXPECT_EQ(collapse_short_edges(m, 0, 0.1), 2u);  // on the top and on the bottom

  ASSERT_EQ(m.positions.size(), 16u);
  for (const std::uint32_t gone : {0u, 9u}) {  // a and its copy below went onto b and its copy
    EXPECT_EQ(std::find(m.positions.begin(), m.positions.end(), before.positions[gone]), m.positions.end());
  }
  EXPECT_EQ(m.positions[0], before.positions[1]);
  EXPECT_EQ(m.positions[8], before.positions[10]);
  expect_closed_oriented_manifold(m);
}

// A bipyramid of radius 10 whose equator edge (0, 1) is split 0.25 Å from vertex 0 by vertex 12 pushed 0.2 Å
// outwards: the split bulges the surface over the centroid of triangle (0, 1, top) by about 0.07 Å. A tetrahedron
// of 0.02 Å sits there, under the bulge: collapsing 12 onto 0 flattens the surface back through it.
TEST(short_edge_collapse, a_collapse_whose_triangles_would_meet_another_triangle_is_undone) {
  surface_mesh m = bulged_bipyramid();
  surface_mesh collapsed_alone = m;
  EXPECT_EQ(collapse_short_edges(collapsed_alone, 0, 0.5), 1u) << "the collapse itself is allowed";
  append(m, small_tetrahedron(), under_the_bulge(m));
  expect_closed_oriented_manifold(m);
  const surface_mesh before = m;
  EXPECT_EQ(collapse_short_edges(m, 0, 0.5), 0u);
  EXPECT_EQ(m.triangles, before.triangles);
  EXPECT_EQ(m.positions, before.positions);
}

// The same bulge over the tetrahedron, and a second split edge far from it, (5, 6) split 0.2 Å from vertex 5 by
// vertex 13. Only the collapse that meets the tetrahedron is refused: the other is made, and the mesh is the one
// without the second split.
TEST(short_edge_collapse, a_collapse_that_fails_is_refused_and_the_others_are_made) {
  surface_mesh m = bulged_bipyramid();
  const std::uint32_t top = 10, bottom = 11;
  const vec3 centre = under_the_bulge(m);
  surface_mesh expected = m;
  append(expected, small_tetrahedron(), centre);

  const std::uint32_t split = 13;
  m.positions.push_back(m.positions[5] + normalized(m.positions[6] - m.positions[5]) * 0.2);
  m.normals.push_back(normalized(m.positions.back()));
  for (triangle& t : m.triangles) {
    if (t == triangle{5, 6, top}) t = {5, split, top};
    if (t == triangle{6, 5, bottom}) t = {6, split, bottom};
  }
  m.triangles.push_back({split, 6, top});
  m.triangles.push_back({split, 5, bottom});
  append(m, small_tetrahedron(), centre);
  expect_closed_oriented_manifold(m);

  EXPECT_EQ(collapse_short_edges(m, 0, 0.5), 1u);
  EXPECT_EQ(m.positions, expected.positions);
  EXPECT_EQ(canonical(m.triangles), canonical(expected.triangles));
  expect_closed_oriented_manifold(m);
}

// The same, among ten thousand other short edges (one in each of as many small bipyramids, side by side): a pass
// that long undoes only the collapse that fails (short_edge_collapse.cpp: undone_alone_from_edges), and every other
// is made.
TEST(short_edge_collapse, among_ten_thousand_short_edges_only_the_one_that_fails_is_refused) {
  surface_mesh m = bulged_bipyramid();
  const vec3 bulge = m.positions[12];
  append(m, small_tetrahedron(), under_the_bulge(m));
  constexpr int others = 10'000;
  const surface_mesh small = bipyramid_with_split_edge(1e-4);
  for (int k = 0; k < others; ++k) append(m, small, {30.0 + 3.0 * (k % 100), 3.0 * (k / 100), 0});
  const std::size_t vertices = m.positions.size();

  EXPECT_EQ(collapse_short_edges(m, 0, 0.5), static_cast<std::size_t>(others));
  EXPECT_EQ(m.positions.size(), vertices - others);
  EXPECT_NE(std::find(m.positions.begin(), m.positions.end(), bulge), m.positions.end()) << "its collapse refused";
  expect_closed_oriented_manifold(m);
}

/// A closed slab: a square top at z = 0 (4 × 4 Å) over a bottom of two triangles at z = −1. The top's short edge
/// (b, a) = (0, 1), 0.05 Å long, is the base of the thin triangle (a, b, e) that is not a face: four vertices lie
/// inside it, so a and b have a third common neighbour, e, besides the corners c and d of the edge's triangles.
/// Top: 0 b (0.05, 0), 1 a (0, 0), 2 e (0.02, 1.2), 3 c (0.025, 0.15), 4 g (0.038, 0.4), 5 k (0.027, 0.8),
/// 6 d (0.025, −1), 7–10 the corners (−2, −2), (2, −2), (2, 2), (−2, 2); 11–14 the corners below them.
surface_mesh slab_with_a_blocked_short_edge() {
  surface_mesh m;
  m.positions = {{0.05, 0, 0}, {0, 0, 0},  {0.02, 1.2, 0}, {0.025, 0.15, 0}, {0.038, 0.4, 0},
                 {0.027, 0.8, 0}, {0.025, -1, 0}, {-2, -2, 0}, {2, -2, 0}, {2, 2, 0}, {-2, 2, 0},
                 {-2, -2, -1}, {2, -2, -1}, {2, 2, -1}, {-2, 2, -1}};
  const std::uint32_t b = 0, a = 1, e = 2, c = 3, g = 4, k = 5, d = 6, B0 = 7, B1 = 8, B2 = 9, B3 = 10;
  m.triangles = {// inside (a, b, e)
                 {a, b, c}, {a, c, e}, {c, b, g}, {g, b, k}, {k, b, e}, {c, g, k}, {c, k, e},
                 // the rest of the top
                 {b, a, d}, {a, B0, d}, {d, B0, B1}, {b, d, B1}, {b, B1, B2}, {b, B2, e}, {e, B2, B3}, {a, e, B3},
                 {a, B3, B0},
                 // the bottom, facing down
                 {11, 13, 12}, {11, 14, 13}};
  for (std::uint32_t i = 0; i < 4; ++i) {  // the sides, between the top's corner 7 + i and the bottom's 11 + i
    const std::uint32_t top = 7 + i, next = 7 + (i + 1) % 4;
    m.triangles.push_back({next, top, top + 4});
    m.triangles.push_back({next, top + 4, next + 4});
  }
  for (const vec3& p : m.positions) m.normals.push_back(p.z == 0 ? vec3{0, 0, 1} : vec3{0, 0, -1});
  return m;
}

TEST(short_edge_collapse, an_edge_whose_ends_have_a_third_common_neighbour_is_left_unless_links_may_be_flipped) {
  surface_mesh m = slab_with_a_blocked_short_edge();
  expect_closed_oriented_manifold(m);
  const surface_mesh before = m;

  EXPECT_EQ(collapse_short_edges(m, 0, 0.1), 0u);  // collapsing it would pinch the top along (a, e)
  EXPECT_EQ(m.triangles, before.triangles);

  // The quality pass flips (a, e) into (c, corner (−2, 2)) first; then a goes onto b.
  EXPECT_EQ(collapse_short_edges(m, 0, 0.1, 8, blocked_links::flipped), 1u);
  EXPECT_EQ(m.positions.size(), before.positions.size() - 1);
  EXPECT_EQ(m.positions[0], before.positions[0]);  // b, the kept end
  EXPECT_EQ(std::find(m.positions.begin(), m.positions.end(), before.positions[1]), m.positions.end());
  expect_closed_oriented_manifold(m);
}

/// bipyramid_with_split_edge(0.05) with its short edge (0, 12) flipped into the long diagonal (top, bottom): a pair of
/// triangles standing in the bipyramid, back to back, whose opposite corners 0 and 12 lie 0.05 Å apart and share no
/// edge (a near-duplicate vertex pair).
surface_mesh bipyramid_with_a_long_diagonal() {
  surface_mesh m = bipyramid_with_split_edge(0.05);
  m.triangles[0] = {11, 12, 10};  // was (0, 12, top)
  m.triangles.back() = {10, 0, 11};  // was (12, 0, bottom)
  return m;
}

TEST(short_edge_collapse, a_long_diagonal_between_close_corners_is_flipped_into_the_short_one) {
  surface_mesh m = bipyramid_with_a_long_diagonal();
  EXPECT_EQ(flip_to_short_diagonals(m, 12, 0.1), 1u);
  EXPECT_EQ(canonical(m.triangles), canonical(bipyramid_with_split_edge(0.05).triangles));
  expect_closed_oriented_manifold(m);
  // The short edge it makes collapses as any other: the bipyramid comes back.
  EXPECT_EQ(collapse_short_edges(m, 12, 0.1), 1u);
  EXPECT_EQ(canonical(m.triangles), canonical(bipyramid().triangles));
}

TEST(short_edge_collapse, a_diagonal_is_left_when_its_corners_may_not_move_or_lie_too_far_apart) {
  for (const auto& [first_movable, max_length] : {std::pair{13u, 0.1}, std::pair{12u, 0.04}}) {
    surface_mesh m = bipyramid_with_a_long_diagonal();
    EXPECT_EQ(flip_to_short_diagonals(m, first_movable, max_length), 0u);
    EXPECT_EQ(m.triangles, bipyramid_with_a_long_diagonal().triangles);
  }
}

}  // namespace
}  // namespace tracemesh
