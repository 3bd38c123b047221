// Tests of core/trace/cell_polygons.hpp (Algorithm 2): a traced_surface is built by hand — roots on the lattice lines
// (closed form for one atom, dense sampling + bisection otherwise), every strip beside a line traced with
// trace_strip — and every cell is closed and triangulated by mesh_cell. The
// cells' triangles, put together, must form a closed surface in which every directed edge appears exactly once and
// its reverse exactly once (orientation from the walls, docs/method.md#orientation-from-the-walls).
#include "core/trace/cell_polygons.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "core/field/gaussian_field.hpp"
#include "core/io/pqr_reader.hpp"
#include "core/mesh.hpp"
#include "core/mesher.hpp"
#include "core/molecule.hpp"
#include "support/atom_list.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

using testing::atoms;

/// Roots of φ = t0 on line (j, k) for x ∈ [lo, hi]: sign changes among samples 0.005 Å apart, refined by bisection.
std::vector<line_point> sampled_roots(const gaussian_field& field, double y, double z, double lo, double hi) {
  std::vector<line_point> out;
  const auto f = [&](double x) { return field.value({x, y, z}) - field.t0(); };
  constexpr double step = 0.005;
  double a = lo, fa = f(a);
  for (double b = lo + step; b <= hi; b += step) {
    const double fb = f(b);
    if ((fa < 0) != (fb < 0)) {
      double l = a, r = b, fl = fa;
      for (int n = 0; n < 80; ++n) {
        const double m = 0.5 * (l + r), fm = f(m);
        if ((fm < 0) == (fl < 0)) {
          l = m;
          fl = fm;
        } else {
          r = m;
        }
      }
      line_point p{0.5 * (l + r), {}};
      field.value_and_gradient({p.x, y, z}, p.gradient);
      out.push_back(p);
    }
    a = b;
    fa = fb;
  }
  return out;
}

/// The lines J, K ∈ [lo, hi] of spacing h with their roots (closed-form ones when `exact_radius` is set: one atom of
/// that radius at the origin).
trace_lines make_lines(const gaussian_field& field, double h, std::int64_t lo, std::int64_t hi,
                       std::optional<double> exact_radius, double x_extent) {
  std::vector<trace_lines::entry> entries;
  for (std::int64_t j = lo; j <= hi; ++j) {
    for (std::int64_t k = lo; k <= hi; ++k) {
      const double y = static_cast<double>(j) * h, z = static_cast<double>(k) * h;
      if (exact_radius) {
        const double rest = *exact_radius * *exact_radius - y * y - z * z;
        if (rest <= 0) continue;
        for (const double x : {-std::sqrt(rest), std::sqrt(rest)}) {
          line_point p{x, {}};
          field.value_and_gradient({x, y, z}, p.gradient);
          entries.push_back({{j, k}, p});
        }
      } else {
        for (const line_point& p : sampled_roots(field, y, z, -x_extent, x_extent)) entries.push_back({{j, k}, p});
      }
    }
  }
  return trace_lines(std::move(entries));
}


/// Traces every strip once; numbers the interior points.
traced_surface trace_surface(const gaussian_field& field, double h, trace_lines lines) {
  traced_surface surface;
  surface.spacing = h;
  surface.lines = std::move(lines);
  strip_settings settings;
  settings.spacing = h;
  settings.max_step = 0.5 * h;
  settings.resample_spacing = h;
  surface.strips = strips_beside(surface.lines);
  for (const strip_id& s : surface.strips) surface.traces.push_back(trace_strip(field, surface.lines, s, settings));
  std::uint32_t next = static_cast<std::uint32_t>(surface.lines.root_count());
  surface.interior_first.clear();
  for (const strip_trace& t : surface.traces) {
    surface.interior_first.push_back(next);
    next += static_cast<std::uint32_t>(t.interior.size());
  }
  return surface;
}

std::vector<cell_id> cells_beside(const traced_surface& surface) {
  std::vector<cell_id> cells;
  for (std::size_t s = 0; s < surface.strips.size(); ++s) {
    if (surface.traces[s].arcs.empty()) continue;
    const strip_id& st = surface.strips[s];
    cells.push_back({st.j, st.k});
    cells.push_back(st.orientation == 0 ? cell_id{st.j, st.k - 1} : cell_id{st.j - 1, st.k});
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  return cells;
}

struct meshed_cells {
  surface_mesh mesh;
  std::vector<cell_id> cells;
  std::vector<cell_mesh> meshes;
};

/// mesh_cell on every cell, assembled like the mesher does: roots, interior points, then each cell's Steiner points.
meshed_cells mesh_all_cells(const gaussian_field& field, const traced_surface& surface) {
  meshed_cells out;
  const double h = surface.spacing;
  for (std::size_t n = 0; n < surface.lines.line_count(); ++n) {
    const line_id& id = surface.lines.id(n);
    for (const line_point& p : surface.lines.roots(n)) {
      out.mesh.positions.push_back({p.x, static_cast<double>(id.j) * h, static_cast<double>(id.k) * h});
      out.mesh.normals.push_back(normalized(-p.gradient));
    }
  }
  for (const strip_trace& t : surface.traces) {
    for (const surface_sample& p : t.interior) {
      out.mesh.positions.push_back(p.position);
      out.mesh.normals.push_back(normalized(-p.gradient));
    }
  }
  out.cells = cells_beside(surface);
  for (const cell_id& c : out.cells) {
    out.meshes.push_back(mesh_cell(field, surface, c));
    const cell_mesh& m = out.meshes.back();
    const auto first_steiner = static_cast<std::uint32_t>(out.mesh.positions.size());
    for (const surface_sample& p : m.steiner) {
      out.mesh.positions.push_back(p.position);
      out.mesh.normals.push_back(normalized(-p.gradient));
    }
    for (auto t : m.triangles) {
      for (auto& v : t) {
        if (v >= steiner_vertex) v = first_steiner + (v - steiner_vertex);
      }
      out.mesh.triangles.push_back(t);
    }
  }
  return out;
}

/// Every directed edge of the mesh appears exactly once, and its reverse exactly once.
void expect_each_directed_edge_once_with_its_reverse(const surface_mesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    for (int c = 0; c < 3; ++c) ++directed[{t[c], t[(c + 1) % 3]}];
  }
  std::size_t bad = 0;
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    const int reverse_count = reverse == directed.end() ? 0 : reverse->second;
    if (count != 1 || reverse_count != 1) {
      if (++bad <= 10) {
        ADD_FAILURE() << "edge " << edge.first << " → " << edge.second << " appears " << count << " times, its reverse "
                      << reverse_count << " times";
      }
    }
  }
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(directed.size(), 3 * mesh.triangles.size());
}

void expect_every_cell_closed(const meshed_cells& m) {
  for (std::size_t c = 0; c < m.cells.size(); ++c) {
    EXPECT_TRUE(m.meshes[c].closed) << "cell (" << m.cells[c].j << ", " << m.cells[c].k << ")";
    EXPECT_FALSE(m.meshes[c].intersecting) << "cell (" << m.cells[c].j << ", " << m.cells[c].k << ")";
    EXPECT_GE(m.meshes[c].loops, 1u) << "cell (" << m.cells[c].j << ", " << m.cells[c].k << ")";
    EXPECT_FALSE(m.meshes[c].triangles.empty());
  }
}

void expect_certified(const surface_mesh& mesh, std::size_t components, long genus) {
  const mesh_report r = analyze_mesh(mesh);
  EXPECT_TRUE(r.topologically_certified())
      << "boundary " << r.boundary_edges << ", non-manifold edges " << r.non_manifold_edges << ", vertices "
      << r.non_manifold_vertices << ", misoriented " << r.inconsistently_oriented_edges << ", degenerate "
      << r.degenerate_triangles << ", intersections " << r.self_intersections << ", inward "
      << r.inward_oriented_components << ", unreferenced " << r.unreferenced_vertices;
  EXPECT_EQ(r.components.size(), components);
  EXPECT_EQ(r.genus, genus);
  EXPECT_GT(r.volume, 0);
}

// One atom of radius 1.8 at the origin, lines 0.7 Å apart through it: no line is tangent, and each cell whose four
// corner lines all cut the sphere holds two loops (the caps at x < 0 and x > 0), a cell on the silhouette one.
TEST(cell_polygons, sphere_cells_chain_closed_loops_into_an_oriented_surface) {
  constexpr double r = 1.8, h = 0.7;
  const gaussian_field field(atoms({{{0, 0, 0}, r, 0}}), -1, 1);
  const traced_surface surface = trace_surface(field, h, make_lines(field, h, -3, 3, r, 0));
  const meshed_cells m = mesh_all_cells(field, surface);
  ASSERT_FALSE(m.cells.empty());
  expect_every_cell_closed(m);
  const auto cut = [&](std::int64_t j, std::int64_t k) { return !surface.lines.roots_of({j, k}).empty(); };
  std::size_t two_loop_cells = 0, one_loop_cells = 0;
  for (std::size_t c = 0; c < m.cells.size(); ++c) {
    const cell_id& id = m.cells[c];
    const int corners = cut(id.j, id.k) + cut(id.j + 1, id.k) + cut(id.j, id.k + 1) + cut(id.j + 1, id.k + 1);
    const std::size_t expected = corners == 4 ? 2 : 1;
    EXPECT_EQ(m.meshes[c].loops, expected)
        << "cell (" << id.j << ", " << id.k << ") with " << corners << " cut corners";
    (expected == 2 ? two_loop_cells : one_loop_cells) += 1;
  }
  EXPECT_GT(two_loop_cells, 0u);
  EXPECT_GT(one_loop_cells, 0u);
  expect_each_directed_edge_once_with_its_reverse(m.mesh);
  // Counter-clockwise seen from outside: every face normal points away from the centre.
  for (const auto& t : m.mesh.triangles) {
    const vec3 a = m.mesh.positions[t[0]], b = m.mesh.positions[t[1]], c = m.mesh.positions[t[2]];
    EXPECT_GT(dot(cross(b - a, c - a), a + b + c), 0);
  }
  for (const vec3& p : m.mesh.positions) EXPECT_NEAR(norm(p), r, 1e-9);
  expect_certified(m.mesh, 1, 0);
  const mesh_report report = analyze_mesh(m.mesh);
  EXPECT_NEAR(report.area, 4 * std::numbers::pi * r * r, 0.12 * 4 * std::numbers::pi * r * r);
}

// Two overlapping atoms (a dumbbell along a diagonal, so that the neck crosses cells obliquely), roots by sampling.
TEST(cell_polygons, dumbbell_cells_chain_closed_loops_into_an_oriented_surface) {
  constexpr double h = 0.6;
  const gaussian_field field(atoms({{{-0.9, -0.55, 0.35}, 1.6, 0}, {{1.1, 0.75, -0.45}, 1.4, 0}}), -1, 1);
  const traced_surface surface = trace_surface(field, h, make_lines(field, h, -6, 6, std::nullopt, 5));
  const meshed_cells m = mesh_all_cells(field, surface);
  ASSERT_FALSE(m.cells.empty());
  expect_every_cell_closed(m);
  expect_each_directed_edge_once_with_its_reverse(m.mesh);
  for (const vec3& p : m.mesh.positions) EXPECT_LE(field.surface_distance(p), 1e-7);
  expect_certified(m.mesh, 1, 0);
}

// A ring of atoms around the x axis (a torus whose hole, ≈ 2 Å wide, runs along x): the lines through the hole hold
// no root, the cells around it two loops each (front and back faces); the handle must survive.
TEST(cell_polygons, torus_around_the_x_axis_keeps_its_handle) {
  constexpr double h = 0.7;
  std::vector<atom> ring;
  constexpr int count = 12;
  for (int n = 0; n < count; ++n) {
    const double angle = 2 * std::numbers::pi * n / count;
    ring.push_back({{0.05, 3.5 * std::cos(angle) + 0.13, 3.5 * std::sin(angle) - 0.21}, 1.5, 0});
  }
  const gaussian_field field(atoms(ring), -1, 1);
  const traced_surface surface = trace_surface(field, h, make_lines(field, h, -8, 8, std::nullopt, 4));
  const meshed_cells m = mesh_all_cells(field, surface);
  ASSERT_FALSE(m.cells.empty());
  expect_every_cell_closed(m);
  expect_each_directed_edge_once_with_its_reverse(m.mesh);
  expect_certified(m.mesh, 1, 1);
}

// A root the lines lack: no arc may end where the line holds no root, so a root of the strip is left without an arc
// and the cells beside that strip cannot close their loops, and say so.
TEST(cell_polygons, a_cell_whose_arc_ends_off_the_lines_reports_it_is_open) {
  constexpr double r = 1.8, h = 0.7;
  const gaussian_field field(atoms({{{0, 0, 0}, r, 0}}), -1, 1);
  trace_lines full = make_lines(field, h, -3, 3, r, 0);
  std::vector<trace_lines::entry> entries = full.entries();
  const auto removed = std::find_if(entries.begin(), entries.end(), [](const trace_lines::entry& e) {
    return e.line == line_id{1, 1} && e.point.x > 0;
  });
  ASSERT_NE(removed, entries.end());
  entries.erase(removed);
  traced_surface surface;
  surface.spacing = h;
  surface.lines = trace_lines(std::move(entries));
  surface.strips = strips_beside(surface.lines);
  strip_settings settings;
  settings.spacing = h;
  settings.max_step = 0.5 * h;
  settings.resample_spacing = h;
  std::uint32_t next = static_cast<std::uint32_t>(surface.lines.root_count());
  for (const strip_id& s : surface.strips) {
    surface.traces.push_back(trace_strip(field, surface.lines, s, settings));
    surface.interior_first.push_back(next);
    next += static_cast<std::uint32_t>(surface.traces.back().interior.size());
  }
  // The four cells around line (1, 1) lack the arc that would end at the missing root.
  for (const cell_id c : {cell_id{0, 0}, cell_id{1, 0}, cell_id{0, 1}, cell_id{1, 1}}) {
    const cell_mesh m = mesh_cell(field, surface, c);
    EXPECT_FALSE(m.closed) << "cell (" << c.j << ", " << c.k << ")";
  }
  // A cell away from it is unaffected.
  EXPECT_TRUE(mesh_cell(field, surface, {-2, -1}).closed);
}

// The same through the whole trace path: the raw mesh of a real molecule, where every cell's polygons are those of
// mesh_cell, has each directed edge once and its reverse once.
TEST(cell_polygons, raw_trace_mesh_of_a_molecule_has_each_directed_edge_once_with_its_reverse) {
  auto mol = read_pqr_file(testing::molecule_path("adp.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  for (const double density : {1.0, 2.0}) {
    mesh_params params;
    params.method = mesh_method::trace;
    params.refine = refine_mode::none;
    params.density = density;
    progress_token progress;
    const auto out = mesh_molecule(*mol, params, {}, progress);
    ASSERT_TRUE(out.ok()) << out.error().message();
    EXPECT_GT(out->trace.polygons, 0u);
    expect_each_directed_edge_once_with_its_reverse(out->mesh);
    expect_certified(out->mesh, 1, 0);
  }
}

/// Meshes `mol` by the trace path at `density` v/Å² with the kernel (d, t0), with and without the quality pass: on
/// the first line grid, certified, no fold.
void expect_meshed_on_the_first_line_grid(const molecule& mol, double d = -1, double t0 = 1, double density = 1) {
  for (const refine_mode refine : {refine_mode::none, refine_mode::full}) {
    mesh_params params;
    params.method = mesh_method::trace;
    params.refine = refine;
    params.d = d;
    params.t0 = t0;
    params.density = density;
    progress_token progress;
    const auto out = mesh_molecule(mol, params, {}, progress);
    ASSERT_TRUE(out.ok()) << out.error().message();
    EXPECT_TRUE(out->fallback_reason.empty()) << out->fallback_reason;
    EXPECT_EQ(out->trace.grid_retries, 0u);
    EXPECT_EQ(out->trace.line_offset, (line_grid_offset{0, 0}));
    EXPECT_TRUE(out->certified);
    EXPECT_EQ(out->report.folded_triangles, 0u);
  }
}

// The atoms of the 2BUK capsid (assembly 1, Mantina radii) within 6 Å of a groove of φ < t0 that crosses the cell
// (j, k) = (−51, 34) diagonally, entering where it grazes the line (−51, 35) over 0.28 Å and leaving through the
// two far walls. The cell's loops are the groove's narrow mouth (four vertices: one arc in each of the two walls
// beside that line) and a long loop that holds the other mouth and a disk of surface beside it: an annulus, but no
// band between the two loops is valid, as the long loop's far edges cannot all reach the small one. Cut open along
// a bridge between them, the annulus is one polygon whose triangulation holds the disk (slit_band).
TEST(cell_polygons, a_tube_whose_mouth_is_a_small_part_of_a_long_loop_is_meshed_on_the_first_line_grid) {
  const molecule groove = atoms({
      {{126.892, -50.761, 30.426}, 1.7, 0}, {{127.589, -51.895, 29.646}, 1.7, 0},
      {{128.823, -51.915, 29.514}, 1.52, 0}, {{127.048, -50.971, 32.848}, 1.7, 0},
      {{125.974, -51.579, 32.969}, 1.52, 0}, {{128.680, -51.873, 34.506}, 1.7, 0},
      {{125.207, -45.751, 27.406}, 1.55, 0}, {{128.004, -46.226, 27.321}, 1.52, 0},
      {{131.400, -49.510, 28.911}, 1.55, 0}, {{126.282, -49.510, 28.286}, 1.7, 0},
      {{131.736, -48.340, 29.777}, 1.7, 0}, {{127.549, -44.182, 30.358}, 1.7, 0},
      {{126.941, -49.435, 29.665}, 1.7, 0}, {{126.224, -48.300, 30.405}, 1.7, 0},
      {{130.557, -48.015, 30.701}, 1.7, 0}, {{130.323, -49.098, 31.589}, 1.52, 0},
      {{126.384, -41.943, 30.736}, 1.7, 0}, {{127.652, -42.774, 30.949}, 1.7, 0},
      {{124.795, -48.661, 30.812}, 1.7, 0}, {{127.560, -50.562, 31.712}, 1.55, 0},
      {{122.803, -49.410, 33.404}, 1.7, 0}, {{124.995, -42.501, 33.936}, 1.52, 0},
      {{127.715, -45.138, 33.982}, 1.7, 0}, {{126.074, -48.452, 34.007}, 1.52, 0},
      {{127.900, -50.632, 34.064}, 1.7, 0}, {{130.670, -42.416, 34.385}, 1.7, 0},
      {{128.638, -45.304, 35.190}, 1.7, 0}, {{129.431, -46.588, 34.932}, 1.7, 0},
      {{126.196, -49.154, 35.021}, 1.7, 0}, {{127.021, -50.180, 35.147}, 1.55, 0},
      {{125.715, -44.234, 36.650}, 1.7, 0}, {{125.047, -45.273, 36.542}, 1.52, 0},
      {{127.021, -44.156, 36.642}, 1.55, 0}, {{127.885, -45.325, 36.522}, 1.7, 0},
      {{125.367, -48.877, 36.275}, 1.7, 0}, {{128.893, -45.318, 37.657}, 1.7, 0},
      {{132.970, -48.568, 30.679}, 1.7, 0}, {{133.408, -47.660, 31.400}, 1.52, 0},
      {{132.769, -46.016, 33.262}, 1.52, 0}, {{133.122, -46.364, 34.528}, 1.7, 0},
      {{132.662, -45.609, 35.613}, 1.7, 0}});
  expect_meshed_on_the_first_line_grid(groove);
}

// The atoms of the 2BUK capsid within 6 Å of a sheet of the surface that lies within 0.1 Å of the wall y = 33·h̃
// of the cell (32, −14) and crosses it back and forth: the cell's loop is a horseshoe around a notch of φ < t0 in
// that wall, whose bottom passes 0.11 Å over the line (33, −14), and of its ten vertices six lie in that wall. No
// triangulation of them exists (the triangle on the notch's lowest vertex must reach a vertex off the wall, and each
// folds), nor a fan around one point; a point of the surface at the neck under the notch splits the loop in two
// halves that are each triangulated (split_at_pinch).
TEST(cell_polygons, a_loop_pinched_under_a_notch_is_split_and_meshed_on_the_first_line_grid) {
  const molecule sheet = atoms({
      {{19.901, 28.199, -13.775}, 1.7, 0}, {{18.592, 28.352, -13.701}, 1.55, 0}, {{18.972, 31.822, -11.881}, 1.7, 0},
      {{19.525, 33.900, -10.689}, 1.7, 0}, {{28.703, 27.684, -15.025}, 1.7, 0}, {{28.748, 30.023, -14.333}, 1.7, 0},
      {{20.474, 28.309, -14.856}, 1.52, 0}, {{25.725, 25.542, -14.312}, 1.52, 0}, {{21.380, 25.469, -12.977}, 1.7, 0},
      {{21.855, 26.906, -12.759}, 1.7, 0}, {{20.707, 27.885, -12.511}, 1.7, 0}, {{26.881, 25.860, -10.784}, 1.7, 0},
      {{27.120, 27.276, -11.313}, 1.7, 0}, {{21.938, 30.041, -9.071}, 1.7, 0}, {{23.165, 26.826, -8.264}, 1.7, 0},
      {{23.204, 29.570, -7.913}, 1.8, 0}, {{22.895, 32.149, -16.735}, 1.52, 0}, {{27.537, 33.282, -16.217}, 1.7, 0},
      {{26.565, 33.580, -15.372}, 1.55, 0}, {{25.128, 33.461, -15.696}, 1.7, 0}, {{23.291, 31.677, -15.671}, 1.7, 0},
      {{24.383, 34.684, -15.141}, 1.7, 0}, {{23.922, 34.681, -13.990}, 1.52, 0}, {{24.591, 32.181, -15.047}, 1.7, 0},
      {{22.592, 30.734, -15.067}, 1.55, 0}, {{20.721, 33.776, -14.865}, 1.52, 0},
      {{27.014, 34.127, -12.797}, 1.52, 0}, {{20.335, 31.535, -11.923}, 1.7, 0}, {{27.053, 33.974, -11.566}, 1.7, 0},
      {{24.998, 32.206, -11.691}, 1.52, 0}, {{20.890, 33.584, -10.748}, 1.7, 0}, {{21.248, 32.374, -11.387}, 1.7, 0},
      {{24.131, 35.955, -10.639}, 1.7, 0}, {{24.963, 35.232, -11.341}, 1.55, 0}, {{25.830, 34.251, -10.702}, 1.7, 0},
      {{25.069, 32.942, -10.478}, 1.7, 0}, {{28.080, 33.582, -10.851}, 1.55, 0}});
  expect_meshed_on_the_first_line_grid(sheet);
}

// The atoms of acetylcholinesterase (mache) within 6 Å of the cell (11, −8) at d = −20, t0 = 10, 0.5 v/Å²: a sheet
// of nearly fused spheres runs 5.6 Å along the cell, touching its walls again and again, and its loop (17 vertices,
// ten of them roots on the corner lines) winds once around the cell. Every triangulation of that loop the
// strategies find crosses itself (long triangles span the length of the sheet and pass through each other), so is
// every single split at a pinch, and no band pairs it with another loop; cut at a few pinches along its length
// (split_at_pinches), each piece triangulates without crossing the others.
TEST(cell_polygons, a_long_sheet_whose_every_triangulation_crosses_itself_is_cut_at_pinches_on_the_first_line_grid) {
  const molecule sheet = atoms({
      {{16.696, 12.379, -10.268}, 1.908, 0}, {{16.744, 12.803, -9.265}, 1.387, 0},
      {{18.041, 12.506, -11.024}, 1.908, 0}, {{18.127, 12.284, -12.231}, 1.661, 0},
      {{19.066, 12.825, -10.245}, 1.824, 0}, {{18.833, 13.010, -9.280}, 1.000, 0},
      {{20.407, 13.213, -10.622}, 1.908, 0}, {{20.458, 13.047, -11.699}, 1.387, 0},
      {{20.512, 14.770, -10.511}, 1.908, 0}, {{21.453, 15.147, -10.911}, 1.487, 0},
      {{20.498, 15.167, -9.496}, 1.487, 0}, {{19.697, 15.249, -11.054}, 1.487, 0},
      {{21.480, 12.357, -9.862}, 1.908, 0}, {{21.376, 11.120, -9.819}, 1.661, 0},
      {{22.550, 12.959, -9.273}, 1.824, 0}, {{22.669, 13.961, -9.320}, 1.000, 0},
      {{23.688, 12.210, -8.834}, 1.908, 0}, {{23.977, 11.512, -9.619}, 1.387, 0},
      {{24.891, 13.100, -8.617}, 1.908, 0}, {{25.701, 12.427, -8.337}, 1.487, 0},
      {{24.767, 13.828, -7.815}, 1.487, 0}, {{25.331, 13.920, -9.832}, 1.908, 0},
      {{26.034, 14.715, -9.584}, 1.487, 0}, {{24.437, 14.478, -10.109}, 1.487, 0},
      {{25.831, 13.050, -11.019}, 1.908, 0}, {{26.439, 12.008, -10.859}, 1.661, 0},
      {{25.578, 13.467, -12.255}, 1.824, 0}, {{24.952, 14.231, -12.467}, 1.000, 0},
      {{26.128, 12.935, -12.914}, 1.000, 0}, {{23.461, 11.341, -7.569}, 1.908, 0},
      {{24.123, 10.335, -7.458}, 1.661, 0}, {{22.660, 11.717, -6.612}, 1.824, 0},
      {{22.193, 12.535, -6.976}, 1.000, 0}, {{22.205, 11.030, -5.407}, 1.908, 0},
      {{23.020, 10.956, -4.688}, 1.387, 0}, {{21.096, 11.897, -4.666}, 1.908, 0},
      {{21.576, 13.296, -4.168}, 1.908, 0}, {{21.672, 13.961, -5.027}, 1.487, 0},
      {{22.446, 13.189, -3.520}, 1.487, 0}, {{20.754, 13.775, -3.636}, 1.487, 0},
      {{19.989, 12.091, -5.518}, 1.721, 0}, {{19.294, 11.815, -4.916}, 1.000, 0}, {{21.227, 9.251, -6.793}, 1.824, 0},
      {{21.254, 9.903, -7.564}, 1.000, 0}});
  expect_meshed_on_the_first_line_grid(sheet, -20, 10, 0.5);
}

// The atoms of acetylcholinesterase (mache) within 2 Å of the cells (−2, −6) and (−1, −6) over x ∈ [20.4, 27.9] at
// d = −8, t0 = 10, 1 v/Å²: a thin tube of the surface crosses the wall y = −h̃ between them, lying almost in it, and
// each cell's loop (25 and 15 vertices) takes the triangulation without the wall rule. Both cells then laid
// triangles in the wall between the same arcs, so that edges of the wall carried four triangles (two of each cell)
// and the quality pass refused the raw mesh on every line grid. Only the cell beyond the wall keeps its triangles
// there; the other is meshed again with the rule kept on that wall.
TEST(cell_polygons, two_cells_beside_a_wall_never_both_lay_triangles_in_it_and_mesh_on_the_first_line_grid) {
  const molecule tube = atoms({
      {{21.068, 1.335, -6.971}, 1.661, 0}, {{23.414, 0.668, -7.113}, 1.387, 0}, {{25.017, 1.286, -5.885}, 1.908, 0},
      {{25.242, 0.104, -5.635}, 1.661, 0}, {{27.658, 1.397, -4.912}, 1.387, 0}, {{26.534, 1.132, -3.201}, 1.908, 0},
      {{27.033, 0.011, -3.026}, 1.661, 0}, {{23.822, -2.295, -2.798}, 1.908, 0}, {{22.950, -2.224, -4.069}, 1.908, 0},
      {{22.476, -3.181, -4.289}, 1.487, 0}, {{23.627, -1.988, -4.890}, 1.487, 0}, {{22.057, -0.976, -3.780}, 1.908, 0},
      {{21.251, -1.427, -3.201}, 1.487, 0}, {{21.598, -0.481, -4.636}, 1.487, 0}, {{23.012, -0.102, -2.979}, 1.908, 0},
      {{23.447, 0.674, -3.609}, 1.387, 0}, {{26.032, -2.682, -3.863}, 1.824, 0}, {{25.899, -1.747, -4.221}, 1.000, 0},
      {{27.355, -3.312, -4.164}, 1.908, 0}, {{28.069, -2.506, -5.241}, 1.908, 0}, {{28.858, -1.947, -4.736}, 1.487, 0},
      {{27.345, -1.784, -5.618}, 1.487, 0}, {{28.633, -3.300, -6.423}, 1.908, 0}});
  expect_meshed_on_the_first_line_grid(tube, -8, 10, 1);
}

// The atoms of acetylcholinesterase (mache) within 4 Å of the cell (33, 28) at d = −8, t0 = 0.1, 2 v/Å², moved so
// that the lines of its second line grid are those of the first: a tube of φ < t0 bent round the corner line
// (33, 29) crosses the cell, entering where that line passes through it between two roots 0.25 Å apart (its mouth:
// a loop of five vertices, one arc in each wall beside the line, which bounds no disk the normals allow) and leaving
// through the two far walls. The best-shaped band between the mouth and the far loop cuts across the bend and
// passes through itself; it is no band, and the annulus is cut open along a bridge instead (slit_band).
TEST(cell_polygons, a_bent_tube_whose_best_band_crosses_itself_is_cut_open_on_the_first_line_grid) {
  const molecule tube = atoms({
      {{5.644, 20.287, 18.857}, 1.824, 0}, {{6.153, 19.415, 18.824}, 1.000, 0}, {{6.401, 21.570, 18.898}, 1.908, 0},
      {{5.709, 22.314, 19.294}, 1.387, 0}, {{7.456, 21.342, 20.075}, 1.908, 0}, {{6.948, 21.298, 21.038}, 1.487, 0},
      {{8.092, 22.217, 20.208}, 1.487, 0}, {{8.386, 20.194, 19.759}, 1.908, 0}, {{9.003, 20.152, 18.706}, 1.661, 0},
      {{8.529, 19.232, 20.604}, 1.824, 0}, {{9.241, 18.545, 20.401}, 1.000, 0}, {{7.783, 19.241, 21.285}, 1.000, 0},
      {{7.053, 22.044, 17.551}, 1.908, 0}, {{7.096, 21.262, 16.607}, 1.661, 0}, {{7.596, 23.277, 17.524}, 1.824, 0},
      {{7.405, 23.727, 18.408}, 1.000, 0}, {{8.529, 23.863, 16.550}, 1.908, 0}, {{7.875, 23.798, 15.681}, 1.387, 0},
      {{8.899, 25.313, 16.970}, 1.908, 0}, {{9.673, 25.325, 17.737}, 1.487, 0}, {{8.000, 25.807, 17.340}, 1.487, 0},
      {{9.771, 22.965, 16.150}, 1.908, 0}, {{10.886, 23.432, 16.138}, 1.661, 0}, {{9.567, 21.726, 15.728}, 1.824, 0},
      {{8.594, 21.456, 15.729}, 1.000, 0}, {{10.589, 20.711, 15.508}, 1.908, 0}, {{10.151, 19.812, 15.941}, 1.387, 0},
      {{11.939, 20.802, 16.304}, 1.908, 0}, {{13.002, 21.158, 15.805}, 1.661, 0},
      {{11.736, 20.638, 17.595}, 1.824, 0}, {{10.802, 20.515, 17.957}, 1.000, 0},
      {{12.868, 20.686, 18.602}, 1.908, 0}, {{13.626, 21.415, 18.317}, 1.387, 0},
      {{12.340, 21.155, 20.025}, 1.908, 0}, {{13.019, 20.804, 20.803}, 1.487, 0},
      {{11.378, 20.691, 20.242}, 1.487, 0}, {{12.042, 22.649, 20.244}, 1.908, 0},
      {{11.820, 23.047, 19.253}, 1.487, 0}, {{10.896, 22.881, 21.221}, 1.908, 0}, {{9.979, 22.717, 20.655}, 1.487, 0},
      {{10.630, 23.882, 21.561}, 1.487, 0}, {{10.998, 22.249, 22.104}, 1.487, 0},
      {{13.295, 23.494, 20.731}, 1.908, 0}, {{12.944, 24.504, 20.940}, 1.487, 0},
      {{14.095, 23.613, 20.000}, 1.487, 0}, {{13.763, 23.035, 21.602}, 1.487, 0},
      {{13.653, 19.358, 18.714}, 1.908, 0}, {{13.025, 18.391, 19.139}, 1.661, 0}});
  expect_meshed_on_the_first_line_grid(tube, -8, 0.1, 2);
}

// The same molecule's atoms within 4 Å of the cell (18, 10) of its third line grid, moved onto the first: the same
// kind of tube, its mouth a loop of four vertices around two roots 0.42 Å apart on the line (18, 11). No band is
// valid, and the polygon cut open along the first bridge that triangulates passes through itself; a later bridge
// gives one that does not.
TEST(cell_polygons, a_bent_tube_is_cut_open_along_the_first_bridge_whose_polygon_does_not_cross_itself) {
  const molecule tube = atoms({
      {{26.119, 9.140, 5.468}, 1.661, 0}, {{26.821, 8.371, 8.032}, 1.908, 0}, {{25.964, 8.996, 8.283}, 1.387, 0},
      {{28.042, 9.257, 7.651}, 1.908, 0}, {{27.915, 10.490, 7.656}, 1.661, 0}, {{29.104, 8.646, 7.102}, 1.824, 0},
      {{30.268, 9.253, 6.562}, 1.908, 0}, {{30.773, 9.734, 7.400}, 1.387, 0}, {{31.232, 8.165, 5.984}, 1.908, 0},
      {{31.901, 8.651, 5.273}, 1.487, 0}, {{33.092, 8.366, 7.869}, 1.908, 0}, {{32.650, 9.262, 8.305}, 1.487, 0},
      {{33.977, 8.635, 7.291}, 1.487, 0}, {{30.032, 10.342, 5.496}, 1.908, 0}, {{30.883, 11.256, 5.481}, 1.661, 0},
      {{28.951, 10.335, 4.773}, 1.824, 0}, {{28.222, 9.641, 4.855}, 1.000, 0}, {{28.570, 11.346, 3.786}, 1.908, 0},
      {{29.475, 11.575, 3.224}, 1.387, 0}, {{26.582, 10.725, 3.396}, 1.487, 0}, {{27.978, 12.655, 4.379}, 1.908, 0},
      {{28.337, 13.787, 3.938}, 1.661, 0}, {{27.105, 12.465, 5.329}, 1.824, 0}, {{26.829, 11.517, 5.544}, 1.000, 0},
      {{26.288, 13.542, 5.762}, 1.908, 0}, {{26.345, 14.335, 5.015}, 1.387, 0}, {{24.765, 13.179, 5.907}, 1.908, 0},
      {{24.649, 12.354, 6.610}, 1.487, 0}, {{26.634, 14.186, 7.101}, 1.908, 0}, {{25.997, 15.066, 7.533}, 1.661, 0},
      {{27.603, 13.575, 7.753}, 1.824, 0}, {{28.083, 12.809, 7.302}, 1.000, 0}, {{28.061, 14.007, 9.086}, 1.908, 0},
      {{27.888, 15.073, 9.238}, 1.387, 0}, {{27.503, 13.157, 10.276}, 1.908, 0}, {{25.509, 13.150, 9.403}, 1.487, 0},
      {{27.758, 11.820, 10.203}, 1.721, 0}, {{27.660, 11.593, 9.275}, 1.000, 0}, {{29.583, 13.828, 9.048}, 1.908, 0},
      {{30.086, 12.714, 8.867}, 1.661, 0}, {{30.269, 14.973, 9.208}, 1.824, 0}, {{29.714, 15.738, 8.851}, 1.000, 0},
      {{31.726, 15.039, 9.434}, 1.908, 0}, {{31.980, 14.079, 9.883}, 1.387, 0}, {{32.394, 15.181, 8.089}, 1.908, 0},
      {{32.243, 16.197, 7.723}, 1.487, 0}, {{31.938, 14.491, 7.379}, 1.487, 0}, {{33.862, 14.908, 8.156}, 1.908, 0},
      {{34.228, 13.730, 8.303}, 1.661, 0}, {{34.703, 15.847, 8.002}, 1.661, 0}});
  expect_meshed_on_the_first_line_grid(tube, -8, 0.1, 2);
}

TEST(cell_polygons, find_strip_returns_the_size_for_an_absent_strip) {
  traced_surface surface;
  surface.strips = {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}};
  EXPECT_EQ(surface.find_strip({0, 1, 0}), 1u);
  EXPECT_EQ(surface.find_strip({1, 0, 0}), 2u);
  EXPECT_EQ(surface.find_strip({1, 1, 0}), 3u);
  EXPECT_EQ(surface.find_strip({0, -1, 0}), 3u);
}

}  // namespace
}  // namespace tracemesh
