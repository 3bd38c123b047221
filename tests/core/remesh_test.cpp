// Tests of core/remesh.hpp and its private helpers core/detail/remesh_*.hpp.
#include "core/remesh.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include "core/detail/remesh_geometry.hpp"
#include "core/detail/remesh_intersections.hpp"
#include "core/detail/remesh_mesh.hpp"
#include "core/detail/remesh_operations.hpp"

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
    return static_cast<std::size_t>(p[0]) + static_cast<std::size_t>(count_[0]) * (p[1] + static_cast<std::size_t>(count_[1]) * p[2]);
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

// --- a local certificate (the project's analyze_mesh checks the same) ---------------------------------------------

struct mesh_facts {
  bool manifold = false;        ///< closed, edge- and vertex-manifold, consistently oriented
  std::size_t intersecting_pairs = 0;
  std::size_t degenerate = 0;
  std::vector<long> euler_characteristics;  ///< per component, sorted
  double area = 0;
  double edge_ratio_mean = 0;
  double fraction_below_0_2 = 0;
  double shortest_edge = 0, median_edge = 0, longest_edge = 0;
  double max_surface_distance = 0;
  double min_normal_agreement = 1;  ///< smallest dot(face normal, mean field normal of its corners)
};

mesh_facts measure(const surface_mesh& mesh, const gaussian_field& field) {
  mesh_facts facts;
  facts.manifold =
      detail::remesh_mesh::build(mesh.positions, std::vector<vec3>(mesh.positions.size()), mesh.triangles).ok();
  facts.intersecting_pairs = detail::find_intersecting_pairs(mesh.positions, mesh.triangles).size();

  std::vector<std::uint32_t> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), 0U);
  const auto root = [&](std::uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  std::vector<double> edges;
  double ratio_sum = 0;
  std::size_t below = 0;
  for (const auto& t : mesh.triangles) {
    const vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const vec3 area = detail::area_vector(a, b, c);
    facts.area += norm(area) / 2;
    if (norm(area) <= 1e-12) ++facts.degenerate;
    const double ratio = detail::edge_ratio(a, b, c);
    ratio_sum += ratio;
    below += ratio < 0.2;
    for (int i = 0; i < 3; ++i) {
      if (t[i] < t[(i + 1) % 3]) edges.push_back(distance(mesh.positions[t[i]], mesh.positions[t[(i + 1) % 3]]));
      parent[root(t[i])] = root(t[(i + 1) % 3]);
    }
    const vec3 mean_normal = normalized(detail::field_normal(field, a) + detail::field_normal(field, b) +
                                        detail::field_normal(field, c));
    facts.min_normal_agreement = std::min(facts.min_normal_agreement, dot(normalized(area), mean_normal));
  }
  std::map<std::uint32_t, std::array<long, 2>> components;  // root → {vertices, faces}
  for (std::uint32_t v = 0; v < mesh.positions.size(); ++v) ++components[root(v)][0];
  for (const auto& t : mesh.triangles) ++components[root(t[0])][1];
  for (const auto& [r, counts] : components) facts.euler_characteristics.push_back(counts[0] - counts[1] / 2);
  std::sort(facts.euler_characteristics.begin(), facts.euler_characteristics.end());

  const double triangles = static_cast<double>(mesh.triangles.size());
  facts.edge_ratio_mean = ratio_sum / triangles;
  facts.fraction_below_0_2 = static_cast<double>(below) / triangles;
  std::sort(edges.begin(), edges.end());
  facts.shortest_edge = edges.front();
  facts.median_edge = edges[edges.size() / 2];
  facts.longest_edge = edges.back();
  for (const vec3& p : mesh.positions) facts.max_surface_distance = std::max(facts.max_surface_distance, field.surface_distance(p));
  return facts;
}

/// The postcondition of remesh_surface, against the facts of its input.
void expect_valid(const surface_mesh& mesh, const gaussian_field& field, const mesh_facts& input_facts) {
  const mesh_facts facts = measure(mesh, field);
  EXPECT_TRUE(facts.manifold);
  EXPECT_EQ(facts.intersecting_pairs, 0U);
  EXPECT_EQ(facts.degenerate, 0U);
  EXPECT_EQ(facts.euler_characteristics, input_facts.euler_characteristics);
  EXPECT_LE(facts.max_surface_distance, 1e-4);
  EXPECT_GT(facts.min_normal_agreement, 0.0);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  ASSERT_EQ(mesh.atom_index.size(), mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    EXPECT_NEAR(dot(mesh.normals[v], detail::field_normal(field, mesh.positions[v])), 1.0, 1e-12);
    EXPECT_EQ(mesh.atom_index[v], field.dominant_atom(mesh.positions[v]));
  }
}

/// Quality targets of the pass at target edge `edge`.
void expect_quality(const surface_mesh& mesh, const gaussian_field& field, double edge) {
  const mesh_facts facts = measure(mesh, field);
  EXPECT_GE(facts.edge_ratio_mean, 0.70);
  EXPECT_LT(facts.fraction_below_0_2, 0.01);
  EXPECT_GE(facts.shortest_edge, 0.1 * facts.median_edge);
  const double density = static_cast<double>(mesh.positions.size()) / facts.area;
  EXPECT_NEAR(density / density_for(edge), 1.0, 0.2) << "vertices " << mesh.positions.size() << " area " << facts.area;
}

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

remesh_options options_for(double edge) {
  remesh_options options;
  options.target_edge = edge;
  return options;
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

}  // namespace
}  // namespace tracemesh
