// Tests of core/remesh/remesh.hpp and its private helpers core/remesh/remesh_*.hpp.
#include "core/remesh/remesh.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include "core/remesh/remesh_geometry.hpp"
#include "core/remesh/remesh_intersections.hpp"
#include "core/remesh/remesh_mesh.hpp"
#include "core/remesh/remesh_operations.hpp"
#include "core/remesh/remesh_patch.hpp"
#include "core/remesh/remesh_stages.hpp"
#include "core/analysis/mesh_analysis.hpp"
#include "support/analysis_meshes.hpp"

namespace tracemesh {
namespace {

using detail::triangle_list;

// --- fixtures -----------------------------------------------------------------------------------------------------

molecule make_molecule(const std::vector<std::pair<vec3, double>>& atoms) {
  molecule mol;
  for (const auto& [center, radius] : atoms) mol.atoms.push_back({center, radius, 0.0});
  return mol;
}

/// A small marching-tetrahedra mesher (Freudenthal split, roots by bisection on the exact field), standing in for
/// the real one: closed, manifold, oriented, free of self-intersections, with the slivers and tiny edges that the
/// remesher exists to remove.
class tiny_marching_tetrahedra {
 public:
  tiny_marching_tetrahedra(const gaussian_field& field, double spacing) : field_(field), h_(spacing) {
    const box3& atoms = field.atom_bounds();
    const double margin = 2 * field.max_radius() + 2 * spacing;
    origin_ = atoms.lo - vec3{margin, margin, margin};
    for (int axis = 0; axis < 3; ++axis) {
      count_[axis] = static_cast<int>(std::ceil((atoms.hi[axis] - atoms.lo[axis] + 2 * margin) / spacing)) + 1;
    }
    values_.resize(static_cast<std::size_t>(count_[0]) * count_[1] * count_[2]);
    for (int k = 0; k < count_[2]; ++k) {
      for (int j = 0; j < count_[1]; ++j) {
        for (int i = 0; i < count_[0]; ++i) values_[index({i, j, k})] = field.value(point({i, j, k}));
      }
    }
  }

  surface_mesh run() {
    for (int k = 0; k + 1 < count_[2]; ++k) {
      for (int j = 0; j + 1 < count_[1]; ++j) {
        for (int i = 0; i + 1 < count_[0]; ++i) triangulate_cube({i, j, k});
      }
    }
    return std::move(mesh_);
  }

 private:
  using lattice_point = std::array<int, 3>;

  std::size_t index(const lattice_point& p) const {
    const auto n0 = static_cast<std::size_t>(count_[0]), n1 = static_cast<std::size_t>(count_[1]);
    return static_cast<std::size_t>(p[0]) + n0 * (static_cast<std::size_t>(p[1]) + n1 * static_cast<std::size_t>(p[2]));
  }
  vec3 point(const lattice_point& p) const { return origin_ + vec3{p[0] * h_, p[1] * h_, p[2] * h_}; }
  bool inside(const lattice_point& p) const { return values_[index(p)] >= field_.t0(); }

  void triangulate_cube(const lattice_point& base) {
    // Six tetrahedra around the main diagonal: 0 → e_a → e_a + e_b → (1,1,1) for each axis order (a, b, c).
    static constexpr int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (const auto& order : orders) {
      lattice_point corners[4] = {base, base, base, base};
      corners[1][order[0]] += 1;
      corners[2] = corners[1];
      corners[2][order[1]] += 1;
      corners[3] = {base[0] + 1, base[1] + 1, base[2] + 1};
      triangulate_tetrahedron(corners);
    }
  }

  void triangulate_tetrahedron(const lattice_point (&corners)[4]) {
    std::vector<lattice_point> in, out;
    for (const auto& c : corners) (inside(c) ? in : out).push_back(c);
    if (in.empty() || out.empty()) return;
    if (in.size() == 2) {
      // Cyclic quad over the cut edges: (i0,o0) (i0,o1) (i1,o1) (i1,o0).
      const std::array<std::pair<lattice_point, lattice_point>, 4> quad{
          {{in[0], out[0]}, {in[0], out[1]}, {in[1], out[1]}, {in[1], out[0]}}};
      emit({quad[0], quad[1], quad[2]}, in, out);
      emit({quad[0], quad[2], quad[3]}, in, out);
    } else {
      const lattice_point& odd = in.size() == 1 ? in[0] : out[0];
      const auto& rest = in.size() == 1 ? out : in;
      emit({{{odd, rest[0]}, {odd, rest[1]}, {odd, rest[2]}}}, in, out);
    }
  }

  /// Emits the triangle over three cut edges, oriented so that its normal points from the inside corners to the
  /// outside ones. The orientation is decided exactly on the edge midpoints (integer arithmetic): it cannot change
  /// as the cut points move along their edges, since the triangle always separates inside from outside corners.
  void emit(std::array<std::pair<lattice_point, lattice_point>, 3> edges, const std::vector<lattice_point>& in,
            const std::vector<lattice_point>& out) {
    std::array<std::array<long, 3>, 3> mid;
    for (int v = 0; v < 3; ++v) {
      for (int axis = 0; axis < 3; ++axis) mid[v][axis] = edges[v].first[axis] + edges[v].second[axis];
    }
    const auto sub = [](const std::array<long, 3>& a, const std::array<long, 3>& b) {
      return std::array<long, 3>{a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    };
    const auto u = sub(mid[1], mid[0]), w = sub(mid[2], mid[0]);
    const std::array<long, 3> n{u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    long direction = 0;  // n · (n_in·Σ out − n_out·Σ in)
    for (int axis = 0; axis < 3; ++axis) {
      long sum_out = 0, sum_in = 0;
      for (const auto& p : out) sum_out += p[axis];
      for (const auto& p : in) sum_in += p[axis];
      direction += n[axis] * (static_cast<long>(in.size()) * sum_out - static_cast<long>(out.size()) * sum_in);
    }
    if (direction < 0) std::swap(edges[1], edges[2]);
    mesh_.triangles.push_back({vertex_on(edges[0]), vertex_on(edges[1]), vertex_on(edges[2])});
  }

  std::uint32_t vertex_on(const std::pair<lattice_point, lattice_point>& edge) {
    std::pair<std::size_t, std::size_t> key{index(edge.first), index(edge.second)};
    if (key.first > key.second) std::swap(key.first, key.second);
    const auto [it, inserted] = vertices_.try_emplace(key, static_cast<std::uint32_t>(mesh_.positions.size()));
    if (inserted) mesh_.positions.push_back(root_on(edge.first, edge.second));
    return it->second;
  }

  /// The root of φ = t0 on a cut edge, kept 1e-4 from its ends.
  vec3 root_on(lattice_point in, lattice_point out) const {
    if (!inside(in)) std::swap(in, out);
    const vec3 a = point(in), b = point(out);
    double lo = 0, hi = 1;  // φ(a + (b − a)·lo) ≥ t0 > φ(a + (b − a)·hi)
    for (int step = 0; step < 60; ++step) {
      const double mid = 0.5 * (lo + hi);
      (field_.value(a + (b - a) * mid) >= field_.t0() ? lo : hi) = mid;
    }
    const double t = std::clamp(0.5 * (lo + hi), 1e-4, 1 - 1e-4);
    return a + (b - a) * t;
  }

  const gaussian_field& field_;
  double h_;
  vec3 origin_;
  std::array<int, 3> count_{};
  std::vector<double> values_;
  std::map<std::pair<std::size_t, std::size_t>, std::uint32_t> vertices_;
  surface_mesh mesh_;
};

surface_mesh marching_tetrahedra(const gaussian_field& field, double spacing) {
  return tiny_marching_tetrahedra(field, spacing).run();
}

/// Vertex density (per Å²) for a target edge L: one vertex per two equilateral triangles.
double density_for(double edge) { return 2 / (std::sqrt(3.0) * edge * edge); }

// --- measuring results --------------------------------------------------------------------------------------------

std::vector<long> euler_characteristics(const mesh_report& report) {
  std::vector<long> chi;
  for (const auto& c : report.components) chi.push_back(c.euler_characteristic);
  std::sort(chi.begin(), chi.end());
  return chi;
}

double max_surface_distance(const surface_mesh& mesh, const gaussian_field& field) {
  double worst = 0;
  for (const vec3& p : mesh.positions) worst = std::max(worst, field.surface_distance(p));
  return worst;
}

/// The postcondition of remesh_surface: certified, same topology as `input`, on the surface (within `tolerance` Å,
/// or as far as the input vertices kept as they are), with field normals.
void expect_valid(const surface_mesh& mesh, const gaussian_field& field, const mesh_report& input,
                  double tolerance = 1e-4) {
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_TRUE(report.topologically_certified())
      << "self-intersections " << report.self_intersections << ", degenerate " << report.degenerate_triangles
      << ", inward components " << report.inward_oriented_components;
  EXPECT_EQ(euler_characteristics(report), euler_characteristics(input));
  EXPECT_EQ(report.genus, input.genus);
  EXPECT_LE(max_surface_distance(mesh, field), tolerance);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  EXPECT_TRUE(mesh.atom_index.empty());  // the mesher's to fill
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    EXPECT_NEAR(dot(mesh.normals[v], detail::field_normal(field, mesh.positions[v])), 1.0, 1e-12);
  }
}

/// Quality targets of the pass at target edge `edge`.
void expect_quality(const surface_mesh& mesh, double edge) {
  const mesh_report report = analyze_mesh(mesh);
  EXPECT_GE(report.quality.edge_ratio_mean, 0.75);
  EXPECT_LT(report.quality.fraction_below_0_2, 0.01);
  EXPECT_GE(report.quality.shortest_edge, 0.1 * report.quality.median_edge);
  EXPECT_NEAR(report.achieved_density / density_for(edge), 1.0, 0.2) << "vertices " << report.vertices;
}

// --- the corner table ----------------------------------------------------------------------------------------------

/// A regular octahedron of radius 1, counter-clockwise from outside.
surface_mesh octahedron() {
  surface_mesh mesh;
  mesh.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  mesh.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return mesh;
}

result<detail::remesh_mesh> corner_table(const surface_mesh& mesh) {
  return detail::remesh_mesh::build(mesh.positions, std::vector<vec3>(mesh.positions.size()), mesh.triangles);
}

/// Rebuilding from the edited mesh's arrays re-derives every adjacency from scratch: it must agree.
void expect_consistent(detail::remesh_mesh& mesh) {
  mesh.compact();
  ASSERT_TRUE(detail::remesh_mesh::build(mesh.positions(), mesh.normals(), mesh.triangles()).ok());
  for (std::uint32_t h = 0; h < mesh.halfedge_slots(); ++h) {
    EXPECT_EQ(mesh.opposite(mesh.opposite(h)), h);
    EXPECT_EQ(mesh.from(mesh.opposite(h)), mesh.to(h));
    EXPECT_EQ(mesh.to(mesh.opposite(h)), mesh.from(h));
  }
  for (std::uint32_t v = 0; v < mesh.vertex_slots(); ++v) EXPECT_EQ(mesh.from(mesh.outgoing(v)), v);
}

TEST(RemeshMesh, BuildsTheOctahedron) {
  auto mesh = corner_table(octahedron());
  ASSERT_TRUE(mesh.ok()) << mesh.error().message();
  for (std::uint32_t v = 0; v < 6; ++v) EXPECT_EQ(mesh->valence(v), 4U);
  std::vector<std::uint32_t> ring;
  mesh->one_ring(4, ring);
  std::sort(ring.begin(), ring.end());
  EXPECT_EQ(ring, (std::vector<std::uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(mesh->find_halfedge(4, 5), detail::no_index);
  const std::uint32_t h = mesh->find_halfedge(0, 2);
  ASSERT_NE(h, detail::no_index);
  EXPECT_EQ(mesh->from(h), 0U);
  EXPECT_EQ(mesh->to(h), 2U);
}

TEST(RemeshMesh, RejectsInvalidMeshes) {
  surface_mesh open = octahedron();
  open.triangles.pop_back();
  EXPECT_EQ(corner_table(open).error().code(), errc::invalid_argument);

  surface_mesh flipped = octahedron();
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  EXPECT_EQ(corner_table(flipped).error().code(), errc::invalid_argument);

  surface_mesh out_of_range = octahedron();
  out_of_range.triangles[0][0] = 6;
  EXPECT_EQ(corner_table(out_of_range).error().code(), errc::invalid_argument);

  surface_mesh unreferenced = octahedron();
  unreferenced.positions.push_back({5, 5, 5});
  EXPECT_EQ(corner_table(unreferenced).error().code(), errc::invalid_argument);

  // Two octahedra glued at one vertex: every edge is fine, the shared vertex has two fans.
  surface_mesh pinched = octahedron();
  const surface_mesh second = octahedron();  // shifted by +2 x, so its vertex 1 lands on the first's vertex 0
  const auto renumber = [](std::uint32_t v) { return v == 1 ? 0U : 6 + v - (v > 1 ? 1 : 0); };
  for (std::uint32_t v = 0; v < 6; ++v) {
    if (v != 1) pinched.positions.push_back(second.positions[v] + vec3{2, 0, 0});
  }
  for (const auto& t : second.triangles) pinched.triangles.push_back({renumber(t[0]), renumber(t[1]), renumber(t[2])});
  EXPECT_EQ(corner_table(pinched).error().code(), errc::invalid_argument);
}

TEST(RemeshMesh, BuildsAnOpenPatchWithItsBoundaryFrozen) {
  // The octahedron's upper half: apex 4 inside, the equator 0–2–1–3 a boundary loop.
  surface_mesh half = octahedron();
  half.triangles.resize(4);
  half.positions.pop_back();  // vertex 5 is no longer used
  EXPECT_EQ(corner_table(half).error().code(), errc::invalid_argument);  // closed meshes only by default
  auto patch = detail::remesh_mesh::build(half.positions, std::vector<vec3>(5), half.triangles, true);
  ASSERT_TRUE(patch.ok()) << patch.error().message();
  EXPECT_EQ(patch->protection(4), detail::vertex_protection::free);
  EXPECT_FALSE(patch->on_boundary(4));
  EXPECT_EQ(patch->valence(4), 4U);
  for (std::uint32_t v = 0; v < 4; ++v) {
    EXPECT_EQ(patch->protection(v), detail::vertex_protection::frozen) << v;
    EXPECT_TRUE(patch->on_boundary(v));
    EXPECT_EQ(patch->valence(v), 3U);  // two equator neighbours and the apex
    EXPECT_EQ(patch->fan_faces(v), 2U);
    std::vector<std::uint32_t> ring;
    patch->one_ring(v, ring);
    std::sort(ring.begin(), ring.end());
    EXPECT_EQ(ring.size(), 3U);
    EXPECT_TRUE(std::binary_search(ring.begin(), ring.end(), 4U));
    EXPECT_EQ(patch->origin(v), v);
  }
  // The equator edge 0→2 has its face; 2→0 would be outside the patch.
  EXPECT_NE(patch->find_halfedge(0, 2), detail::no_index);
  EXPECT_EQ(patch->find_halfedge(2, 0), detail::no_index);
}

TEST(RemeshMesh, EditsKeepTheCornerTableConsistent) {
  auto built = corner_table(octahedron());
  ASSERT_TRUE(built.ok());
  detail::remesh_mesh mesh = std::move(built.value());
  const std::uint32_t m = mesh.split_edge(mesh.find_halfedge(0, 2), {0.5, 0.5, 0}, {});
  EXPECT_EQ(mesh.valence(m), 4U);
  EXPECT_EQ(mesh.valence(4), 5U);
  EXPECT_EQ(mesh.live_face_count(), 10U);
  expect_consistent(mesh);

  // Flip 4–5's neighbour edge 0–4 (valences 4 and 5) towards the apexes.
  const std::uint32_t h = mesh.find_halfedge(0, 4);
  const std::uint32_t c = mesh.apex(h), d = mesh.apex(mesh.opposite(h));
  mesh.flip_edge(h);
  EXPECT_EQ(mesh.find_halfedge(0, 4), detail::no_index);
  EXPECT_NE(mesh.find_halfedge(c, d), detail::no_index);
  expect_consistent(mesh);

  const std::size_t vertices = mesh.live_vertex_count();
  const std::uint32_t g = mesh.find_halfedge(1, 3);
  ASSERT_NE(g, detail::no_index);
  mesh.collapse_edge(g, {-0.5, -0.5, 0}, {});
  EXPECT_EQ(mesh.live_vertex_count(), vertices - 1);
  EXPECT_EQ(mesh.position(1), (vec3{-0.5, -0.5, 0}));
  expect_consistent(mesh);
  const auto triangles = mesh.triangles();
  EXPECT_EQ(static_cast<long>(mesh.live_vertex_count()) - static_cast<long>(triangles.size()) / 2, 2);  // χ = 2
}

TEST(RemeshMesh, ColouringSeparatesNeighbours) {
  auto mesh = corner_table(octahedron());
  ASSERT_TRUE(mesh.ok());
  mesh->set_protection(5, detail::vertex_protection::locked);
  const auto classes = detail::colour_free_vertices(mesh.value());
  std::vector<int> colour(6, -1);
  for (std::size_t c = 0; c < classes.size(); ++c) {
    for (const std::uint32_t v : classes[c]) colour[v] = static_cast<int>(c);
  }
  EXPECT_EQ(colour[5], -1);  // a locked vertex never moves
  std::vector<std::uint32_t> ring;
  for (std::uint32_t v = 0; v < 5; ++v) {
    ASSERT_GE(colour[v], 0);
    mesh->one_ring(v, ring);
    for (const std::uint32_t x : ring) EXPECT_NE(colour[x], colour[v]) << v << " " << x;
  }
}

// --- intersections and projection ---------------------------------------------------------------------------------

TEST(RemeshIntersections, ListsThePairsTheCertificateCounts) {
  // Two interpenetrating tetrahedra, and a third far away.
  surface_mesh mesh = testing::tetrahedron({0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2});
  testing::append(mesh, testing::tetrahedron({0.5, 0.5, 0.5}, {3, 0.5, 0.5}, {0.5, 3, 0.5}, {0.5, 0.5, 3}));
  testing::append(mesh, testing::tetrahedron({10, 0, 0}, {12, 0, 0}, {10, 2, 0}, {10, 0, 2}));
  const auto pairs = detail::find_intersecting_pairs(mesh, detail::classify_triangles(mesh));
  EXPECT_EQ(pairs.size(), count_self_intersections(mesh));
  ASSERT_FALSE(pairs.empty());
  for (const auto& pair : pairs) {
    EXPECT_LT(pair[0], 4U);  // one face of the first tetrahedron...
    EXPECT_GE(pair[1], 4U);  // ...with one of the second
    EXPECT_LT(pair[1], 8U);
  }
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end()));

  const auto offending = detail::find_offending_triangles(mesh);
  EXPECT_FALSE(offending.empty());
  for (const std::uint32_t t : offending) EXPECT_LT(t, 8U);
  EXPECT_TRUE(detail::find_offending_triangles(testing::icosphere(3, 2.0)).empty());
}

TEST(RemeshIntersections, ComponentsOrientedAgainstTheirNormalsOffend) {
  // Two tetrahedra apart: the first with outward vertex normals, the second with inward ones.
  surface_mesh mesh = testing::tetrahedron({0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2});
  testing::append(mesh, testing::tetrahedron({10, 0, 0}, {12, 0, 0}, {10, 2, 0}, {10, 0, 2}));
  const vec3 centres[2] = {{0.5, 0.5, 0.5}, {10.5, 0.5, 0.5}};
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const vec3 outward = normalized(mesh.positions[v] - centres[v < 4 ? 0 : 1]);
    mesh.normals.push_back(v < 4 ? outward : -outward);
  }
  const auto defects = detail::classify_triangles(mesh);
  EXPECT_EQ(detail::find_inward_component_triangles(mesh, defects), (std::vector<std::uint32_t>{4, 5, 6, 7}));
  EXPECT_EQ(detail::find_offending_triangles(mesh), (std::vector<std::uint32_t>{4, 5, 6, 7}));
  EXPECT_EQ(analyze_mesh(mesh).inward_oriented_components, 1u) << "the certificate's count";
  mesh.normals.clear();
  EXPECT_TRUE(detail::find_inward_component_triangles(mesh, defects).empty()) << "no normals, nothing to compare";
  EXPECT_TRUE(detail::find_offending_triangles(mesh).empty());
}

TEST(RemeshIntersections, DegenerateTrianglesOffend) {
  surface_mesh mesh = testing::icosphere(1, 1.0);
  mesh.positions[mesh.triangles[5][1]] = mesh.positions[mesh.triangles[5][0]];  // a zero-length edge
  const auto offending = detail::find_offending_triangles(mesh);
  EXPECT_NE(std::find(offending.begin(), offending.end(), 5U), offending.end());
}

TEST(RemeshGeometry, ProjectsOntoTheSurfaceWithItsNormal) {
  const gaussian_field field(make_molecule({{{1, 2, 3}, 1.5}}), -1.0, 1.0);  // the sphere of radius 1.5
  vec3 p{1 + 1.9, 2 + 0.2, 3 - 0.1}, n;
  ASSERT_TRUE(detail::project_onto_surface(field, p, n, 1.0, 1e-7));
  EXPECT_LE(field.surface_distance(p), 1e-7);
  EXPECT_NEAR(distance(p, {1, 2, 3}), 1.5, 1e-6);
  EXPECT_NEAR(dot(n, normalized(p - vec3{1, 2, 3})), 1.0, 1e-9);

  vec3 far{1 + 4.0, 2, 3}, unused;
  EXPECT_FALSE(detail::project_onto_surface(field, far, unused, 1.0, 1e-7));  // 2.5 Å away, max move 1 Å
  EXPECT_EQ(far, (vec3{5, 2, 3}));
}

// --- verified stages -----------------------------------------------------------------------------------------------

/// A sphere of radius 2 around the origin, as an icosphere on the single atom's surface, in a corner table.
struct sphere_fixture {
  gaussian_field field{make_molecule({{{0, 0, 0}, 2.0}}), -1.0, 1.0};
  surface_mesh mesh = testing::icosphere(3, 2.0);
  detail::remesh_mesh state = build();
  detail::remesh_thresholds thresholds = thresholds_for(0.5);
  progress_token progress;

  detail::remesh_mesh build() const {
    std::vector<vec3> normals;
    for (const vec3& p : mesh.positions) normals.push_back(normalized(p));
    return detail::remesh_mesh::build(mesh.positions, normals, mesh.triangles).value();
  }
  static detail::remesh_thresholds thresholds_for(double edge) {
    detail::remesh_thresholds t;
    t.split_above = 4.0 / 3 * edge;
    t.collapse_below = 0.8 * edge;
    t.tiny_below = 0.2 * edge;
    t.max_edge_after_collapse = t.split_above;
    t.min_normal_cosine = std::cos(70 * 3.14159265358979 / 180);
    t.quality_floor = 0.25;
    t.hard_quality_floor = 1e-6;
    t.max_move = edge;
    t.surface_tolerance = 1e-7;
    return t;
  }
};

/// A destructive stage: slides every vertex within 0.1 Å of `target` 0.8 Å sideways along the sphere, past its
/// neighbours (about 0.3 Å away), folding its fan over theirs.
detail::remesh_stage fold_at(const vec3& target) {
  return [target](detail::remesh_mesh& mesh, detail::remesh_operations&) {
    for (std::uint32_t v = 0; v < mesh.vertex_slots(); ++v) {
      if (distance(mesh.position(v), target) > 0.1) continue;
      const vec3 p = mesh.position(v);
      const vec3 sideways = normalized(cross(p, vec3{0.3, 0.5, 0.8}));
      mesh.move_vertex(v, normalized(p + sideways * 0.8) * norm(p), mesh.normal(v));
    }
    return true;
  };
}

TEST(RemeshStages, ASettlingStageReportsTheTrianglesItLeftUnclean) {
  sphere_fixture f;
  const vec3 target = f.mesh.positions[0];
  detail::verified_stages stages(f.field, f.thresholds, 1'000'000, f.progress);
  const result<bool> clean = stages.run(f.state, fold_at(target), true);
  ASSERT_TRUE(clean.ok());
  EXPECT_FALSE(clean.value());
  // The offending triangles are those of the folded fans, all near the target.
  const detail::check_failure& failure = stages.last_failure();
  ASSERT_FALSE(failure.offending.empty());
  for (const std::uint32_t t : failure.offending) {
    const auto& tri = failure.mesh.triangles[t];
    const vec3 centre = (failure.mesh.positions[tri[0]] + failure.mesh.positions[tri[1]] +
                         failure.mesh.positions[tri[2]]) / 3;
    EXPECT_LT(distance(centre, target), 1.5) << t;
  }
  // A stage that is not settled is not checked.
  sphere_fixture g;
  detail::verified_stages unchecked(g.field, g.thresholds, 1'000'000, g.progress);
  EXPECT_TRUE(unchecked.run(g.state, fold_at(target), false).value());
}

TEST(RemeshStages, SettlesPlacedVerticesAndStopsOnCancellation) {
  sphere_fixture f;
  // Lift vertex 5 slightly off the sphere (a placed vertex): settling puts it back.
  const detail::remesh_stage lift = [](detail::remesh_mesh& mesh, detail::remesh_operations&) {
    mesh.move_vertex(5, mesh.position(5) * 1.01, mesh.normal(5));
    return true;
  };
  detail::verified_stages stages(f.field, f.thresholds, 1'000'000, f.progress);
  ASSERT_TRUE(stages.run(f.state, lift, true).value());
  EXPECT_NEAR(norm(f.state.position(5)), 2.0, 1e-6);
  EXPECT_LE(f.field.surface_distance(f.state.position(5)), 1e-7);

  const detail::remesh_stage cancelled = [](detail::remesh_mesh&, detail::remesh_operations&) { return false; };
  EXPECT_EQ(stages.run(f.state, cancelled, false).error().code(), errc::cancelled);
  detail::verified_stages tight(f.field, f.thresholds, 10, f.progress);
  EXPECT_EQ(tight.run(f.state, lift, false).error().code(), errc::limit_exceeded);
}

TEST(RemeshStages, FreezeNearMarksPointsAroundListedTriangles) {
  const surface_mesh mesh = testing::icosphere(2, 1.0);
  std::vector<std::uint8_t> frozen(mesh.positions.size(), 0);
  frozen[3] = 1;  // already frozen: not counted again
  const std::size_t added = detail::freeze_near(mesh.positions, mesh.positions, mesh.triangles, {0}, 0.3, frozen);
  const auto& t = mesh.triangles[0];
  for (const std::uint32_t v : t) EXPECT_TRUE(frozen[v]);
  std::size_t count = 0;
  for (std::uint32_t v = 0; v < frozen.size(); ++v) {
    const vec3 centre = (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3;
    if (v != 3 && distance(mesh.positions[v], centre) > 1.0) {
      EXPECT_FALSE(frozen[v]) << v;
    }
    count += frozen[v];
  }
  EXPECT_EQ(count, added + 1);  // vertex 3 was frozen before
  EXPECT_GT(added, 3U);
}

// --- remesh_surface ---------------------------------------------------------------------------------------------

struct remesh_run {
  surface_mesh mesh;
  remesh_stats stats;
};

remesh_run remesh_ok(surface_mesh mesh, const gaussian_field& field, const remesh_options& options) {
  progress_token progress;
  result<remesh_stats> stats = remesh_surface(mesh, field, options, progress);
  EXPECT_TRUE(stats.ok()) << stats.error().message();
  return {std::move(mesh), stats.ok() ? stats.value() : remesh_stats{}};
}

/// remesh_ok in an arena of `threads` threads.
remesh_run remesh_on_threads(const surface_mesh& input, const gaussian_field& field, const remesh_options& options,
                             int threads) {
  tbb::task_arena arena(threads);
  remesh_run run;
  arena.execute([&] { run = remesh_ok(input, field, options); });
  return run;
}

remesh_options options_for(double edge) {
  remesh_options options;
  options.target_edge = edge;
  return options;
}

/// Meshes `atoms` with the test's marching tetrahedra at `spacing`, remeshes at `edge` and checks the
/// postcondition and the quality targets.
void expect_remeshed_well(const std::vector<std::pair<vec3, double>>& atoms, double spacing, double edge) {
  const gaussian_field field(make_molecule(atoms), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, spacing);
  const mesh_report before = analyze_mesh(input);
  ASSERT_TRUE(before.topologically_certified());
  ASSERT_LT(before.quality.edge_ratio_mean, 0.6);  // the input really is poor

  const remesh_run run = remesh_ok(input, field, options_for(edge));
  EXPECT_EQ(run.stats.rounds, 1);
  EXPECT_FALSE(run.stats.input_returned);
  EXPECT_GT(run.stats.collapses + run.stats.splits, 0U);
  // Every relaxation moved with one Newton step (a field evaluation); projections count too.
  EXPECT_GT(run.stats.field_evaluations, run.stats.relaxations + run.stats.splits);
  expect_valid(run.mesh, field, before);
  expect_quality(run.mesh, edge);
}

TEST(RemeshSurface, OneAtom) { expect_remeshed_well({{{0.3, -0.2, 0.1}, 2.0}}, 0.5, 0.5); }

TEST(RemeshSurface, OverlappingAtoms) {
  expect_remeshed_well({{{0, 0, 0}, 1.6}, {{2.2, 0.3, 0}, 1.4}, {{1.0, 1.9, 0.5}, 1.2}, {{1.1, 0.8, 1.8}, 1.0}}, 0.4,
                       0.45);
}

TEST(RemeshSurface, RefinesACoarseInput) {
  // Target edges shorter than the input's: splits dominate.
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.8}, {{2.0, 0, 0}, 1.5}}), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.8);
  const mesh_report before = analyze_mesh(input);
  const remesh_run run = remesh_ok(input, field, options_for(0.3));
  EXPECT_GT(run.stats.splits, run.stats.collapses);
  expect_valid(run.mesh, field, before);
  expect_quality(run.mesh, 0.3);
}

TEST(RemeshSurface, KeepsTheGenusOfARing) {
  std::vector<std::pair<vec3, double>> ring;
  for (int k = 0; k < 10; ++k) {
    const double angle = 2 * 3.14159265358979 * k / 10;
    ring.push_back({{3.5 * std::cos(angle), 3.5 * std::sin(angle), 0.2 * (k % 2)}, 1.3});
  }
  const gaussian_field field(make_molecule(ring), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.45);
  const mesh_report before = analyze_mesh(input);
  ASSERT_EQ(before.genus, 1);
  const remesh_run run = remesh_ok(input, field, options_for(0.5));
  expect_valid(run.mesh, field, before);
  expect_quality(run.mesh, 0.5);
}

TEST(RemeshSurface, KeepsSeparateComponents) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.5}, {{6, 0, 0}, 1.2}}), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.4);
  const mesh_report before = analyze_mesh(input);
  ASSERT_EQ(before.components.size(), 2U);
  const remesh_run run = remesh_ok(input, field, options_for(0.45));
  expect_valid(run.mesh, field, before);
  EXPECT_EQ(analyze_mesh(run.mesh).components.size(), 2U);
}

TEST(RemeshSurface, IsDeterministicWhateverTheThreadCount) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.6}, {{2.1, 0.4, 0}, 1.3}, {{0.9, 1.8, 0.6}, 1.1}}), -1.0,
                             1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.35);
  const auto run_with = [&](int threads) { return remesh_on_threads(input, field, options_for(0.4), threads); };
  const remesh_run one = run_with(1), two = run_with(2), again = run_with(2);
  EXPECT_EQ(one.mesh.triangles, two.mesh.triangles);
  EXPECT_EQ(one.mesh.positions, two.mesh.positions);  // bitwise
  EXPECT_EQ(one.mesh.normals, two.mesh.normals);
  EXPECT_EQ(two.mesh.positions, again.mesh.positions);
  EXPECT_EQ(one.stats.relaxations, two.stats.relaxations);
  EXPECT_EQ(one.stats.field_evaluations, two.stats.field_evaluations);
}

TEST(RemeshSurface, AMeshAlreadyMeetingTheTargetsOnlyHasItsFinalRelaxation) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.6}, {{2.1, 0.4, 0}, 1.3}, {{0.9, 1.8, 0.6}, 1.1}}), -1.0,
                             1.0);
  const remesh_run first = remesh_ok(marching_tetrahedra(field, 0.35), field, options_for(0.4));
  const mesh_report refined = analyze_mesh(first.mesh);
  ASSERT_GE(refined.quality.edge_ratio_mean, 0.8);  // meets the default targets
  ASSERT_EQ(refined.quality.fraction_below_0_2, 0.0);

  // Passed again, it ends its iterations before the first: no split, collapse or flip, a fraction of the work.
  const remesh_run again = remesh_ok(first.mesh, field, options_for(0.4));
  EXPECT_EQ(again.stats.splits + again.stats.collapses + again.stats.flips, 0U);
  EXPECT_GT(again.stats.relaxations, 0U);
  EXPECT_LT(2 * again.stats.field_evaluations, first.stats.field_evaluations);
  expect_valid(again.mesh, field, refined);
  EXPECT_GE(analyze_mesh(again.mesh).quality.edge_ratio_mean, refined.quality.edge_ratio_mean - 0.01);

  // Told never to end early, the same pass iterates.
  remesh_options always = options_for(0.4);
  always.done_edge_ratio_mean = 2;
  const remesh_run iterated = remesh_ok(first.mesh, field, always);
  EXPECT_GT(iterated.stats.splits + iterated.stats.collapses + iterated.stats.flips, 0U);
  EXPECT_GT(iterated.stats.field_evaluations, again.stats.field_evaluations);
}

/// A protein-like chain: 24 overlapping atoms wound along x over ~55 Å, with crevices between them.
gaussian_field chain_field() {
  std::vector<std::pair<vec3, double>> atoms;
  for (int i = 0; i < 24; ++i) {
    atoms.push_back({{2.2 * i, 1.2 * std::sin(i), 1.0 * std::cos(1.3 * i)}, 1.3 + 0.1 * (i % 3)});
  }
  return gaussian_field(make_molecule(atoms), -1.0, 1.0);
}

/// Options that cut a small mesh into several chunks (see remesh_chunks.hpp).
remesh_options chunked_options(double edge) {
  remesh_options options = options_for(edge);
  options.single_patch_triangles = 0;
  options.chunk_edges = 16;
  return options;
}

TEST(RemeshSurface, ChunkedPassKeepsTheCertificateAndReachesTheQuality) {
  const gaussian_field field = chain_field();
  const surface_mesh input = marching_tetrahedra(field, 0.35);
  const mesh_report before = analyze_mesh(input);
  ASSERT_TRUE(before.topologically_certified());
  const remesh_run run = remesh_ok(input, field, chunked_options(0.4));
  EXPECT_GE(run.stats.patches, 3U);  // ~55 Å long; chunks of 12 cells of ~1.2 Å (twice the longest edge)
  EXPECT_EQ(run.stats.unchanged_patches, 0U);
  EXPECT_FALSE(run.stats.input_returned);
  expect_valid(run.mesh, field, before);
  expect_quality(run.mesh, 0.4);
  // The chunk seams are remeshed too: no trace of the marching-tetrahedra slivers is left anywhere.
  EXPECT_GT(analyze_mesh(run.mesh).quality.edge_ratio_min, 0.1);
}

TEST(RemeshSurface, ChunkedPassIsDeterministicWhateverTheThreadCount) {
  const gaussian_field field = chain_field();
  const surface_mesh input = marching_tetrahedra(field, 0.35);
  const auto run_with = [&](int threads) { return remesh_on_threads(input, field, chunked_options(0.4), threads); };
  const remesh_run one = run_with(1), two = run_with(2);
  EXPECT_EQ(one.mesh.triangles, two.mesh.triangles);
  EXPECT_EQ(one.mesh.positions, two.mesh.positions);  // bitwise
  EXPECT_EQ(one.mesh.normals, two.mesh.normals);
  EXPECT_EQ(one.stats.patches, two.stats.patches);
}

/// The triangles of `mesh` with an edge longer than `edge`, as their corner positions.
std::vector<std::array<vec3, 3>> triangles_with_an_edge_over(const surface_mesh& mesh, double edge) {
  std::vector<std::array<vec3, 3>> out;
  for (const auto& t : mesh.triangles) {
    const std::array<vec3, 3> p{mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]};
    if (distance(p[0], p[1]) > edge || distance(p[1], p[2]) > edge || distance(p[2], p[0]) > edge) out.push_back(p);
  }
  return out;
}

TEST(RemeshSurface, TrianglesLongerThanHalfACellStayOutOfThePatches) {
  // A coarse input (edges up to √3 · 0.9 Å) remeshed to L = 0.35 Å: natural cells of 48 L / 12 = 1.4 Å, grown to
  // at most 2.8 Å (chunks of 6 such cells), so the triangles with an edge over 1.4 Å (57 of 5,840) stay as they are
  // and every other one is remeshed.
  const gaussian_field field = chain_field();
  const surface_mesh input = marching_tetrahedra(field, 0.9);
  const mesh_report before = analyze_mesh(input);
  ASSERT_TRUE(before.topologically_certified());
  const std::vector<std::array<vec3, 3>> long_input = triangles_with_an_edge_over(input, 1.4);
  ASSERT_FALSE(long_input.empty());
  ASSERT_LT(long_input.size(), input.triangles.size() / 4);
  remesh_options options = options_for(0.35);
  options.single_patch_triangles = 0;
  options.final_collapse_below = 0;  // the patches alone: the final collapses may remove a long triangle's short edge
  const remesh_run run = remesh_ok(input, field, options);
  // ~55 Å long. The cells grew to 2.8 Å, but a chunk stays about 48 L = 16.8 Å wide (6 cells): 4 patches, where
  // 12 grown cells a chunk made 2, each redoing twice as much after a failed round.
  EXPECT_GE(run.stats.patches, 4U);
  EXPECT_EQ(run.stats.unchanged_patches, 0U);
  // The long triangles' vertices are the input's (this marching-tetrahedra mesh puts them within ~1e-4 Å).
  expect_valid(run.mesh, field, before, std::max(1e-4, max_surface_distance(input, field)));
  // Each long triangle is in the output, bitwise; the rest reached the target edge length.
  const std::vector<std::array<vec3, 3>> long_output = triangles_with_an_edge_over(run.mesh, 1.4);
  EXPECT_EQ(long_output.size(), long_input.size());
  for (const auto& t : long_input) {
    const bool kept = std::any_of(long_output.begin(), long_output.end(), [&](const std::array<vec3, 3>& u) {
      return u[0] == t[0] && u[1] == t[1] && u[2] == t[2];
    });
    EXPECT_TRUE(kept);
  }
  // Everything else was remeshed as a single patch would have: about as many triangles.
  const remesh_run whole = remesh_ok(input, field, options_for(0.35));
  EXPECT_NEAR(static_cast<double>(run.mesh.triangles.size()) / static_cast<double>(whole.mesh.triangles.size()), 1.0,
              0.05);
}

// unchecked_below_triangles: a whole mesh under it is not checked at the end of its round. Where the check would have
// found nothing, that is the checked pass's very mesh; patches are checked against their context whatever it says.
TEST(RemeshSurface, AWholeMeshLeftUncheckedIsTheCheckedMeshWhenThatIsClean) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.6}, {{2.1, 0.4, 0}, 1.3}, {{0.9, 1.8, 0.6}, 1.1}}), -1.0,
                             1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.35);
  remesh_options unchecked = options_for(0.4);
  unchecked.unchecked_below_triangles = input.triangles.size() + 1;
  const remesh_run checked_run = remesh_ok(input, field, options_for(0.4));
  const remesh_run unchecked_run = remesh_ok(input, field, unchecked);
  EXPECT_FALSE(checked_run.stats.unchecked);
  EXPECT_TRUE(unchecked_run.stats.unchecked);
  EXPECT_EQ(unchecked_run.mesh.triangles, checked_run.mesh.triangles);
  EXPECT_EQ(unchecked_run.mesh.positions, checked_run.mesh.positions);  // bitwise

  unchecked.unchecked_below_triangles = input.triangles.size();  // "fewer than": this mesh is checked
  EXPECT_FALSE(remesh_ok(input, field, unchecked).stats.unchecked);

  const gaussian_field chain = chain_field();
  const surface_mesh chain_input = marching_tetrahedra(chain, 0.35);
  remesh_options chunked = chunked_options(0.4);
  chunked.unchecked_below_triangles = chain_input.triangles.size() + 1;
  const remesh_run patches = remesh_ok(chain_input, chain, chunked);
  EXPECT_FALSE(patches.stats.unchecked);
  EXPECT_EQ(patches.mesh.positions, remesh_ok(chain_input, chain, chunked_options(0.4)).mesh.positions);
}

TEST(RemeshPatch, KeepsAPatchThatWouldCutItsContext) {
  // A patch whose input already crosses a fixed context triangle can never pass its check: it comes back as it was.
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.5}}), -1.0, 1.0);
  const surface_mesh sphere = marching_tetrahedra(field, 0.4);
  detail::remesh_patch_input patch;
  patch.positions = sphere.positions;
  for (const vec3& p : sphere.positions) patch.normals.push_back(detail::field_normal(field, p));
  patch.triangles = sphere.triangles;
  detail::remesh_patch_context context;
  const auto n = static_cast<std::uint32_t>(patch.positions.size());
  context.positions = {{-5, -5, 0.01}, {5, -5, 0.01}, {0, 5, 0.01}};  // a plane through the sphere
  context.triangles = {{n, n + 1, n + 2}};
  progress_token progress;
  auto cut = detail::remesh_patch(patch, context, field, options_for(0.45), progress);
  ASSERT_TRUE(cut.ok()) << cut.error().message();
  EXPECT_TRUE(cut->stats.input_returned);
  EXPECT_EQ(cut->mesh.triangles, patch.triangles);
  EXPECT_EQ(cut->mesh.positions, patch.positions);

  // The same patch with the context moved away is remeshed.
  context.positions = {{-5, -5, 9}, {5, -5, 9}, {0, 5, 9}};
  auto free = detail::remesh_patch(patch, context, field, options_for(0.45), progress);
  ASSERT_TRUE(free.ok());
  EXPECT_FALSE(free->stats.input_returned);
  EXPECT_LT(free->mesh.triangles.size(), patch.triangles.size());
}

TEST(RemeshSurface, HonoursCancellation) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.5}, {{2.0, 0, 0}, 1.5}}), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.4);

  surface_mesh mesh = input;
  progress_token cancelled_before;
  cancelled_before.cancel();
  EXPECT_EQ(remesh_surface(mesh, field, options_for(0.45), cancelled_before).error().code(), errc::cancelled);
  EXPECT_EQ(mesh.positions, input.positions);
  EXPECT_EQ(mesh.triangles, input.triangles);

  // Cancelled from the listener once the pass has reported some progress.
  progress_token* self = nullptr;
  std::atomic<int> reports{0};
  progress_token midway([&](mesh_stage stage, double fraction) {
    EXPECT_EQ(stage, mesh_stage::refining);
    EXPECT_GE(fraction, 0.0);
    EXPECT_LE(fraction, 1.0);
    if (++reports == 3) self->cancel();
  });
  self = &midway;
  EXPECT_EQ(remesh_surface(mesh, field, options_for(0.45), midway).error().code(), errc::cancelled);
  EXPECT_GE(reports.load(), 3);
  EXPECT_EQ(mesh.positions, input.positions);
  EXPECT_EQ(mesh.triangles, input.triangles);
}

TEST(RemeshSurface, RefusesBadArgumentsAndLeavesTheMesh) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.5}}), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.5);
  progress_token progress;
  const auto expect_refused = [&](surface_mesh mesh, const remesh_options& options, errc code) {
    const surface_mesh before = mesh;
    EXPECT_EQ(remesh_surface(mesh, field, options, progress).error().code(), code);
    EXPECT_EQ(mesh.positions, before.positions);
    EXPECT_EQ(mesh.triangles, before.triangles);
  };
  for (const double edge : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    expect_refused(input, options_for(edge), errc::invalid_argument);
  }
  remesh_options inverted = options_for(0.5);
  inverted.collapse_below = 1.5;  // above split_above: would oscillate
  expect_refused(input, inverted, errc::invalid_argument);
  remesh_options negative_iterations = options_for(0.5);
  negative_iterations.iterations = -1;
  expect_refused(input, negative_iterations, errc::invalid_argument);
  remesh_options negative_done = options_for(0.5);
  negative_done.done_edge_ratio_mean = -0.1;
  expect_refused(input, negative_done, errc::invalid_argument);

  surface_mesh open = input;
  open.triangles.pop_back();
  expect_refused(open, options_for(0.5), errc::invalid_argument);

  remesh_options small_budget = options_for(0.05);  // ~28 Å² at 0.05 Å edges: ~50,000 triangles
  small_budget.max_triangles = 10'000;
  expect_refused(input, small_budget, errc::limit_exceeded);
}

TEST(RemeshSurface, ZeroIterationsOnlyFillsTheVertexData) {
  const gaussian_field field(make_molecule({{{0, 0, 0}, 1.5}}), -1.0, 1.0);
  const surface_mesh input = marching_tetrahedra(field, 0.5);
  remesh_options options = options_for(0.5);
  options.iterations = 0;
  options.final_relaxations = 0;
  options.final_collapse_below = 0;
  const remesh_run run = remesh_ok(input, field, options);
  EXPECT_EQ(run.mesh.positions, input.positions);
  EXPECT_EQ(run.mesh.triangles, input.triangles);
  expect_valid(run.mesh, field, analyze_mesh(input));
}

}  // namespace
}  // namespace tracemesh
