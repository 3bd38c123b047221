#include "core/remesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "core/detail/remesh_geometry.hpp"
#include "core/detail/remesh_intersections.hpp"
#include "core/detail/remesh_mesh.hpp"
#include "core/detail/remesh_operations.hpp"

namespace tracemesh {
namespace {

using detail::remesh_mesh;
using detail::triangle_list;
using detail::vertex_protection;

constexpr double pi = 3.14159265358979323846;
constexpr int max_iterations = 100;

status invalid(const std::string& what) { return {errc::invalid_argument, "remesh: " + what}; }

status check_options(const remesh_options& o) {
  if (!(o.target_edge > 0) || !std::isfinite(o.target_edge)) return invalid("target_edge must be a positive length");
  if (o.iterations < 0 || o.iterations > max_iterations) return invalid("iterations must be in [0, 100]");
  if (o.final_relaxations < 0 || o.final_relaxations > max_iterations) {
    return invalid("final_relaxations must be in [0, 100]");
  }
  if (!(o.tiny_edge_below > 0 && o.tiny_edge_below <= o.collapse_below && o.collapse_below < o.split_above &&
        std::isfinite(o.split_above))) {
    return invalid("edge thresholds must satisfy 0 < tiny_edge_below <= collapse_below < split_above");
  }
  if (!(o.max_normal_deviation_deg > 0 && o.max_normal_deviation_deg < 90)) {
    return invalid("max_normal_deviation_deg must be in (0, 90)");
  }
  if (!(o.hard_quality_floor > 0 && o.hard_quality_floor <= o.quality_floor && o.quality_floor <= 1)) {
    return invalid("quality floors must satisfy 0 < hard_quality_floor <= quality_floor <= 1");
  }
  if (!(o.surface_tolerance > 0 && o.surface_tolerance <= 1e-4)) {
    return invalid("surface_tolerance must be in (0, 1e-4] Å");
  }
  if (!(o.freeze_radius > 0) || !std::isfinite(o.freeze_radius)) return invalid("freeze_radius must be positive");
  if (o.max_rounds < 1) return invalid("max_rounds must be at least 1");
  return status::success();
}

detail::remesh_thresholds thresholds_for(const remesh_options& o) {
  const double l = o.target_edge;
  detail::remesh_thresholds t;
  t.split_above = o.split_above * l;
  t.collapse_below = o.collapse_below * l;
  t.tiny_below = o.tiny_edge_below * l;
  t.max_edge_after_collapse = o.split_above * l;
  t.min_normal_cosine = std::cos(o.max_normal_deviation_deg * pi / 180);
  t.quality_floor = o.quality_floor;
  t.hard_quality_floor = o.hard_quality_floor;
  t.max_move = l;
  t.surface_tolerance = o.surface_tolerance;
  return t;
}

template <class Body>
void parallel_over(std::size_t count, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) body(i);
  });
}

std::vector<vec3> field_normals(const gaussian_field& field, const std::vector<vec3>& positions) {
  std::vector<vec3> normals(positions.size());
  parallel_over(positions.size(), [&](std::size_t v) { normals[v] = detail::field_normal(field, positions[v]); });
  return normals;
}

double surface_area(const std::vector<vec3>& positions, const triangle_list& triangles) {
  double twice = 0;
  for (const auto& t : triangles) twice += norm(detail::area_vector(positions[t[0]], positions[t[1]], positions[t[2]]));
  return twice / 2;
}

/// Euler characteristic of each connected component, sorted: with closedness, the topology to preserve.
std::vector<long> component_euler_characteristics(std::size_t vertex_count, const triangle_list& triangles) {
  std::vector<std::uint32_t> parent(vertex_count);
  std::iota(parent.begin(), parent.end(), 0U);
  const auto root = [&](std::uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto& t : triangles) {
    for (int i = 1; i < 3; ++i) {
      const std::uint32_t a = root(t[0]), b = root(t[i]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<long> vertices(vertex_count, 0), faces(vertex_count, 0);
  for (std::uint32_t v = 0; v < vertex_count; ++v) ++vertices[root(v)];
  for (const auto& t : triangles) ++faces[root(t[0])];
  std::vector<long> chi;
  for (std::uint32_t v = 0; v < vertex_count; ++v) {
    if (root(v) == v) chi.push_back(vertices[v] - faces[v] * 3 / 2 + faces[v]);  // V − E + F, E = 3F/2 (closed)
  }
  std::sort(chi.begin(), chi.end());
  return chi;
}

/// Marks every point within `radius` (at least; bounding boxes are used) of a listed triangle. Returns how many
/// points became frozen.
std::size_t freeze_near(const std::vector<vec3>& points, const std::vector<vec3>& triangle_positions,
                        const triangle_list& triangles, const std::vector<std::uint32_t>& listed, double radius,
                        std::vector<std::uint8_t>& frozen) {
  struct region {
    box3 bounds;
  };
  std::vector<region> regions;
  double largest = radius;
  for (const std::uint32_t t : listed) {
    box3 b{triangle_positions[triangles[t][0]], triangle_positions[triangles[t][0]]};
    for (const std::uint32_t v : triangles[t]) {
      for (int axis = 0; axis < 3; ++axis) {
        b.lo[axis] = std::min(b.lo[axis], triangle_positions[v][axis] - radius);
        b.hi[axis] = std::max(b.hi[axis], triangle_positions[v][axis] + radius);
      }
    }
    for (int axis = 0; axis < 3; ++axis) largest = std::max(largest, b.hi[axis] - b.lo[axis]);
    regions.push_back({b});
  }
  // Hash regions into cells at least as large as any region: a point only checks the regions of its own cell.
  using cell_key = std::array<std::int64_t, 3>;
  const auto cell_of = [&](const vec3& p) {
    return cell_key{static_cast<std::int64_t>(std::floor(p.x / largest)),
                    static_cast<std::int64_t>(std::floor(p.y / largest)),
                    static_cast<std::int64_t>(std::floor(p.z / largest))};
  };
  std::vector<std::pair<cell_key, std::uint32_t>> cells;
  for (std::uint32_t r = 0; r < regions.size(); ++r) {
    const cell_key lo = cell_of(regions[r].bounds.lo), hi = cell_of(regions[r].bounds.hi);
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) cells.push_back({{x, y, z}, r});
      }
    }
  }
  std::sort(cells.begin(), cells.end());
  std::vector<std::uint8_t> newly(points.size(), 0);
  parallel_over(points.size(), [&](std::size_t v) {
    if (frozen[v]) return;
    const cell_key key = cell_of(points[v]);
    auto it = std::lower_bound(cells.begin(), cells.end(), std::pair<cell_key, std::uint32_t>{key, 0});
    for (; it != cells.end() && it->first == key; ++it) {
      const box3& b = regions[it->second].bounds;
      const vec3& p = points[v];
      if (p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z) {
        newly[v] = 1;
        return;
      }
    }
  });
  std::size_t count = 0;
  for (std::size_t v = 0; v < points.size(); ++v) {
    if (newly[v]) {
      frozen[v] = 1;
      ++count;
    }
  }
  return count;
}

/// Frozen input vertices become frozen, their other neighbours locked (see vertex_protection).
void protect(remesh_mesh& mesh, const std::vector<std::uint8_t>& frozen) {
  std::vector<std::uint32_t> ring;
  for (std::uint32_t v = 0; v < frozen.size(); ++v) {
    if (!frozen[v]) continue;
    mesh.set_protection(v, vertex_protection::frozen);
    mesh.one_ring(v, ring);
    for (const std::uint32_t x : ring) {
      if (!frozen[x]) mesh.set_protection(x, vertex_protection::locked);
    }
  }
}

struct round_output {
  surface_mesh mesh;  ///< positions, normals and triangles
  detail::operation_counts counts;
};

/// One full remeshing of `work` (a copy of the input with its protection set).
result<round_output> run_round(remesh_mesh work, const gaussian_field& field, const remesh_options& options,
                               progress_token& progress) {
  const detail::remesh_thresholds t = thresholds_for(options);
  detail::remesh_operations ops(work, field, t, progress);
  const status cancelled{errc::cancelled, "remesh: cancelled"};
  const int steps = options.iterations + options.final_relaxations;
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    const bool go = (iteration > 0 || ops.collapse_short_edges(t.tiny_below)) && ops.split_long_edges() &&
                    ops.collapse_short_edges(t.collapse_below) && ops.flip_edges_for_valence() &&
                    ops.relax_vertices();
    if (!go) return cancelled;
    work.compact();
    if (work.live_face_count() > options.max_triangles) {
      return status{errc::limit_exceeded, "remesh: more than max_triangles triangles"};
    }
    if (!progress.report(mesh_stage::refining, static_cast<double>(iteration + 1) / (steps + 1))) return cancelled;
  }
  for (int sweep = 0; sweep < options.final_relaxations; ++sweep) {
    if (!ops.relax_vertices()) return cancelled;
    if (!progress.report(mesh_stage::refining, static_cast<double>(options.iterations + sweep + 1) / (steps + 1))) {
      return cancelled;
    }
  }
  work.compact();
  round_output out;
  out.mesh.positions = work.positions();
  out.mesh.normals = work.normals();
  out.mesh.triangles = work.triangles();
  out.counts = ops.counts();
  return out;
}

void write_mesh(surface_mesh& mesh, const gaussian_field& field, std::vector<vec3> positions,
                std::vector<vec3> normals, triangle_list triangles) {
  std::vector<std::uint32_t> atoms(positions.size());
  parallel_over(positions.size(), [&](std::size_t v) { atoms[v] = field.dominant_atom(positions[v]); });
  mesh.positions = std::move(positions);
  mesh.normals = std::move(normals);
  mesh.triangles = std::move(triangles);
  mesh.atom_index = std::move(atoms);
}

}  // namespace

result<remesh_stats> remesh_surface(surface_mesh& mesh, const gaussian_field& field, const remesh_options& options,
                                    progress_token& progress) {
  if (status s = check_options(options); !s) return s;
  remesh_stats stats;
  std::vector<vec3> input_normals = options.trust_input_normals && mesh.normals.size() == mesh.positions.size()
                                        ? mesh.normals
                                        : field_normals(field, mesh.positions);
  if (mesh.triangles.empty() && mesh.positions.empty()) {
    write_mesh(mesh, field, {}, {}, {});
    return stats;
  }
  result<remesh_mesh> input = remesh_mesh::build(mesh.positions, input_normals, mesh.triangles);
  if (!input) return input.error();

  const double l = options.target_edge;
  const double expected_triangles = 4 * surface_area(mesh.positions, mesh.triangles) / (std::sqrt(3.0) * l * l);
  if (expected_triangles > static_cast<double>(options.max_triangles)) {
    return status{errc::limit_exceeded, "remesh: the target edge length would give more than max_triangles triangles"};
  }
  const std::vector<long> input_topology = component_euler_characteristics(mesh.positions.size(), mesh.triangles);

  std::vector<std::uint8_t> frozen(mesh.positions.size(), 0);
  std::size_t frozen_count = 0;
  for (int round = 1; round <= options.max_rounds; ++round) {
    stats.rounds = round;
    if (!progress.report(mesh_stage::refining, 0.0)) return status{errc::cancelled, "remesh: cancelled"};
    remesh_mesh work = input.value();
    protect(work, frozen);
    result<round_output> out = run_round(std::move(work), field, options, progress);
    if (!out) return out.error();

    surface_mesh& result_mesh = out->mesh;
    const std::vector<std::uint32_t> bad = detail::find_offending_triangles(result_mesh);
    const bool topology_kept =
        component_euler_characteristics(result_mesh.positions.size(), result_mesh.triangles) == input_topology &&
        remesh_mesh::build(result_mesh.positions, result_mesh.normals, result_mesh.triangles).ok();
    if (!topology_kept) break;  // cannot happen by construction; never hand out a broken mesh
    if (bad.empty()) {
      stats.splits = out->counts.splits;
      stats.collapses = out->counts.collapses;
      stats.flips = out->counts.flips;
      stats.relaxations = out->counts.relaxations;
      stats.rejected_ops = out->counts.rejected;
      stats.frozen_vertices = frozen_count;
      write_mesh(mesh, field, std::move(result_mesh.positions), std::move(result_mesh.normals),
                 std::move(result_mesh.triangles));
      return stats;
    }
    const double radius = options.freeze_radius * l * std::ldexp(1.0, round - 1);
    const std::size_t added =
        freeze_near(mesh.positions, result_mesh.positions, result_mesh.triangles, bad, radius, frozen);
    frozen_count += added;
    if (added == 0 || frozen_count == frozen.size()) break;
  }
  // No clean result: keep the (valid) input.
  stats.input_returned = true;
  stats.frozen_vertices = frozen_count;
  write_mesh(mesh, field, mesh.positions, std::move(input_normals), mesh.triangles);
  return stats;
}

}  // namespace tracemesh
