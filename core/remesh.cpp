#include "core/remesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "core/detail/remesh_geometry.hpp"
#include "core/detail/remesh_mesh.hpp"
#include "core/detail/remesh_operations.hpp"
#include "core/detail/remesh_stages.hpp"

namespace tracemesh {
namespace {

using detail::remesh_mesh;
using detail::triangle_list;

constexpr double pi = 3.14159265358979323846;
constexpr int max_iterations = 100;
/// Tries of a stage with a growing frozen region, after its first, before it is skipped.
constexpr int max_stage_retries = 4;

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

/// One round (see remesh.hpp): the tiny-edge sweep, the iterations and the final relaxation, each verified.
/// Returns whether `state` ended clean and settled on the surface (else `stages.last_failure()` says where not).
result<bool> run_round(remesh_mesh& state, detail::verified_stages& stages, const remesh_options& options,
                       progress_token& progress) {
  const detail::remesh_thresholds t = thresholds_for(options);
  const int stage_count = options.iterations + 2;
  const auto report = [&](int done) {
    return progress.report(mesh_stage::refining, static_cast<double>(done) / stage_count);
  };
  const status cancelled{errc::cancelled, "remesh: cancelled"};
  // Tiny edges first, as a stage of their own: a region frozen later then keeps none of them. A skipped stage
  // (false) leaves the state as it was, clean.
  if (options.iterations > 0) {
    const auto tiny_edges = [&](remesh_mesh&, detail::remesh_operations& ops) {
      return ops.collapse_short_edges(t.tiny_below);
    };
    if (result<bool> done = stages.run(state, tiny_edges, false); !done) return done;
    if (!report(1)) return cancelled;
  }
  const auto iteration = [&](remesh_mesh&, detail::remesh_operations& ops) {
    return ops.split_long_edges() && ops.collapse_short_edges(t.collapse_below) && ops.flip_edges_for_valence() &&
           ops.relax_vertices();
  };
  for (int k = 0; k < options.iterations; ++k) {
    if (result<bool> done = stages.run(state, iteration, false); !done) return done;
    if (!report(k + 2)) return cancelled;
  }
  const auto final_relaxation = [&](remesh_mesh&, detail::remesh_operations& ops) {
    for (int sweep = 0; sweep < options.final_relaxations; ++sweep) {
      if (!ops.relax_vertices()) return false;
    }
    return true;
  };
  result<bool> settled = stages.run(state, final_relaxation, true);
  if (settled && !settled.value()) {
    // The relaxation could not be made clean: settle the vertices where they are.
    const auto no_operation = [](remesh_mesh&, detail::remesh_operations&) { return true; };
    settled = stages.run(state, no_operation, true);
  }
  return settled;
}

void record_operations(const detail::verified_stages& stages, const remesh_mesh& state, remesh_stats& stats) {
  const detail::operation_counts& counts = stages.counts();
  stats.splits = counts.splits;
  stats.collapses = counts.collapses;
  stats.flips = counts.flips;
  stats.relaxations = counts.relaxations;
  stats.rejected_ops = counts.rejected;
  const std::vector<std::uint8_t> frozen = detail::frozen_flags(state);
  stats.frozen_vertices = static_cast<std::size_t>(std::count(frozen.begin(), frozen.end(), 1));
}

void write_mesh(surface_mesh& mesh, const gaussian_field& field, std::vector<vec3> positions, std::vector<vec3> normals,
                triangle_list triangles) {
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
  if (!progress.report(mesh_stage::refining, 0.0)) return status{errc::cancelled, "remesh: cancelled"};
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

  // Second level of safety: should a round end unclean, restart from the input with its vertices near the
  // offending triangles frozen, until clean (at worst everything is frozen and the input comes back).
  std::vector<std::uint8_t> frozen_input(mesh.positions.size(), 0);
  for (int round = 1; round <= options.max_rounds; ++round) {
    stats.rounds = round;
    remesh_mesh state = input.value();
    detail::protect(state, frozen_input);
    detail::verified_stages stages(field, thresholds_for(options),
                                   {options.max_triangles, options.freeze_radius * l, max_stage_retries}, progress);
    result<bool> clean = run_round(state, stages, options, progress);
    if (!clean) return clean.error();
    stats.retried_stages += stages.retried_stages();
    if (clean.value()) {
      surface_mesh out = detail::certificate_view(state);
      // Cannot differ by construction; checked so that a bug never hands out a broken mesh.
      if (component_euler_characteristics(out.positions.size(), out.triangles) != input_topology ||
          !remesh_mesh::build(out.positions, out.normals, out.triangles).ok()) {
        break;
      }
      record_operations(stages, state, stats);
      write_mesh(mesh, field, std::move(out.positions), std::move(out.normals), std::move(out.triangles));
      return stats;
    }
    const detail::check_failure& failure = stages.last_failure();
    const double radius = options.freeze_radius * l * std::ldexp(1.0, round - 1);
    if (detail::freeze_near(mesh.positions, failure.mesh.positions, failure.mesh.triangles, failure.offending, radius,
                            frozen_input) == 0) {
      break;
    }
  }
  // No clean result: keep the (valid) input.
  stats.input_returned = true;
  stats.frozen_vertices = static_cast<std::size_t>(std::count(frozen_input.begin(), frozen_input.end(), 1));
  write_mesh(mesh, field, mesh.positions, std::move(input_normals), mesh.triangles);
  return stats;
}

}  // namespace tracemesh
