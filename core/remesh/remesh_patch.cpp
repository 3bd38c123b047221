#include "core/remesh/remesh_patch.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <tuple>
#include <utility>

#include "core/remesh/remesh_geometry.hpp"
#include "core/remesh/remesh_intersections.hpp"
#include "core/remesh/remesh_operations.hpp"
#include "core/remesh/remesh_stages.hpp"

namespace tracemesh::detail {
namespace {

constexpr double pi = 3.14159265358979323846;
constexpr int max_iterations = 100;
/// The quality report's threshold of a poor triangle (quality_report::fraction_below_0_2).
constexpr double poor_edge_ratio = 0.2;

status invalid(const std::string& what) { return {errc::invalid_argument, "remesh: " + what}; }

remesh_thresholds thresholds_for(const remesh_options& o) {
  const double l = o.target_edge;
  remesh_thresholds t;
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

/// One component's topology: its Euler characteristic and the smallest input index among its boundary vertices
/// (no_index for a closed component). Fixed boundaries and equal lists mean the same surface up to homeomorphism.
using component_topology = std::pair<long, std::uint32_t>;

std::vector<component_topology> topology_of(const remesh_mesh& mesh) {
  const std::uint32_t n = mesh.vertex_slots();
  std::vector<std::uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0U);
  const auto root = [&](std::uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (std::uint32_t f = 0; f < mesh.face_slots(); ++f) {
    if (mesh.face_removed(f)) continue;
    const auto t = mesh.face(f);
    for (int i = 1; i < 3; ++i) {
      const std::uint32_t a = root(t[0]), b = root(t[i]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<long> vertices(n, 0), faces(n, 0), open_halfedges(n, 0);
  std::vector<std::uint32_t> boundary_key(n, no_index);
  for (std::uint32_t v = 0; v < n; ++v) {
    if (mesh.vertex_removed(v)) continue;
    const std::uint32_t r = root(v);
    ++vertices[r];
    if (mesh.on_boundary(v)) boundary_key[r] = std::min(boundary_key[r], mesh.origin(v));
  }
  for (std::uint32_t f = 0; f < mesh.face_slots(); ++f) {
    if (mesh.face_removed(f)) continue;
    const std::uint32_t r = root(mesh.face(f)[0]);
    ++faces[r];
    for (std::uint32_t h = 3 * f; h < 3 * f + 3; ++h) open_halfedges[r] += mesh.opposite(h) == no_index;
  }
  std::vector<component_topology> components;
  for (std::uint32_t v = 0; v < n; ++v) {
    if (mesh.vertex_removed(v) || root(v) != v) continue;
    const long edges = (3 * faces[v] + open_halfedges[v]) / 2;
    components.emplace_back(vertices[v] - edges + faces[v], boundary_key[v]);
  }
  std::sort(components.begin(), components.end());
  return components;
}

bool all_frozen(const remesh_mesh& mesh, const std::array<std::uint32_t, 3>& t) {
  return mesh.protection(t[0]) == vertex_protection::frozen && mesh.protection(t[1]) == vertex_protection::frozen &&
         mesh.protection(t[2]) == vertex_protection::frozen;
}

/// The certificate's check of a patch, extended by the pairs of its triangles with the context triangles that
/// meet its bounding box (no other can cut it).
offending_finder finder_with(const remesh_patch_context& context, std::uint32_t input_vertices) {
  if (context.triangles.empty() && !context.bounded) return {};
  return [&context, input_vertices](const remesh_mesh& mesh, const surface_mesh& view) {
    std::vector<std::uint32_t> all(view.triangles.size());
    std::iota(all.begin(), all.end(), 0U);
    if (view.positions.empty()) return std::vector<std::uint32_t>{};
    const box3 extent = bounds_of(view.positions);
    if (context.bounded && !context.reach.contains(extent)) return all;
    // Boundary vertices are never removed: every context corner on the patch has a current index.
    std::vector<std::uint32_t> current(input_vertices, no_index);
    for (std::uint32_t v = 0; v < mesh.vertex_slots(); ++v) {
      if (!mesh.vertex_removed(v) && mesh.origin(v) != no_index) current[mesh.origin(v)] = v;
    }
    // Patch triangles with three frozen corners were neither made nor unmade (no edit touches a frozen vertex's
    // faces): like the context triangles, they are known not to meet each other.
    enum group : std::uint8_t { moving, unchanged_patch, fixed_context };
    std::vector<std::uint8_t> groups(view.triangles.size(), moving);
    for (std::uint32_t t = 0; t < view.triangles.size(); ++t) {
      if (all_frozen(mesh, view.triangles[t])) groups[t] = unchanged_patch;
    }
    surface_mesh combined;
    combined.positions = view.positions;
    combined.positions.insert(combined.positions.end(), context.positions.begin(), context.positions.end());
    combined.triangles = view.triangles;
    const auto patch_vertices = static_cast<std::uint32_t>(view.positions.size());
    for (const auto& t : context.triangles) {
      std::array<std::uint32_t, 3> mapped{};
      for (int i = 0; i < 3; ++i) {
        mapped[i] = t[i] < input_vertices ? current[t[i]] : patch_vertices + (t[i] - input_vertices);
        if (mapped[i] == no_index) return all;  // cannot happen (see above); refuse rather than guess
      }
      if (extent.meets(bounds_of(combined.positions, mapped))) {
        combined.triangles.push_back(mapped);
        groups.push_back(fixed_context);
      }
    }
    std::vector<std::uint32_t> offending = find_offending_triangles(combined, groups);  // combined has no normals
    const auto own = static_cast<std::uint32_t>(view.triangles.size());
    offending.erase(std::lower_bound(offending.begin(), offending.end(), own), offending.end());
    const std::vector<std::uint32_t> inward = find_inward_component_triangles(view, classify_triangles(view));
    if (!inward.empty()) {
      offending.insert(offending.end(), inward.begin(), inward.end());
      std::sort(offending.begin(), offending.end());
      offending.erase(std::unique(offending.begin(), offending.end()), offending.end());
    }
    return offending;
  };
}

/// Whether the triangles of `mesh` that the pass may still change (a corner not frozen) meet the targets that end
/// the iterations (remesh_options::done_edge_ratio_mean and done_poor_share); true when there are none.
bool meets_done_targets(const remesh_mesh& mesh, const remesh_options& options) {
  double ratio_sum = 0;
  std::size_t count = 0, poor = 0;
  for (std::uint32_t f = 0; f < mesh.face_slots(); ++f) {
    if (mesh.face_removed(f)) continue;
    const auto t = mesh.face(f);
    if (all_frozen(mesh, t)) continue;
    const double ratio = edge_ratio(mesh.position(t[0]), mesh.position(t[1]), mesh.position(t[2]));
    ratio_sum += ratio;
    poor += ratio < poor_edge_ratio;
    ++count;
  }
  const auto n = static_cast<double>(count);
  return ratio_sum >= options.done_edge_ratio_mean * n && static_cast<double>(poor) <= options.done_poor_share * n;
}

/// One round (see remesh.hpp): the tiny-edge sweep, the iterations and the final relaxation. Returns whether
/// `state` ended clean and settled on the surface (else `stages.last_failure()` says where not).
result<bool> run_round(remesh_mesh& state, verified_stages& stages, const remesh_options& options,
                       progress_token& progress, bool report_stages) {
  const remesh_thresholds t = thresholds_for(options);
  const int stage_count = options.iterations + 2;
  const status cancelled{errc::cancelled, "remesh: cancelled"};
  const auto report = [&](int done) {
    if (!report_stages) return !progress.cancelled();
    return progress.report(mesh_stage::refining, static_cast<double>(done) / stage_count);
  };
  // Tiny edges first, as a stage of their own.
  if (options.iterations > 0) {
    const auto tiny_edges = [&](remesh_mesh&, remesh_operations& ops) {
      return ops.collapse_short_edges(t.tiny_below);
    };
    if (result<bool> done = stages.run(state, tiny_edges, false); !done) return done;
    if (!report(1)) return cancelled;
  }
  const auto iteration = [&](remesh_mesh&, remesh_operations& ops) {
    return ops.split_long_edges() && ops.collapse_short_edges(t.collapse_below) && ops.flip_edges_for_valence() &&
           ops.relax_vertices();
  };
  for (int k = 0; k < options.iterations; ++k) {
    if (meets_done_targets(state, options)) break;
    if (result<bool> done = stages.run(state, iteration, false); !done) return done;
    if (!report(k + 2)) return cancelled;
  }
  const auto final_relaxation = [&](remesh_mesh&, remesh_operations& ops) {
    for (int sweep = 0; sweep < options.final_relaxations; ++sweep) {
      if (!ops.relax_vertices()) return false;
    }
    return true;
  };
  return stages.run(state, final_relaxation, true);
}

void record_operations(const verified_stages& stages, const remesh_mesh& state, remesh_stats& stats) {
  const operation_counts& counts = stages.counts();
  stats.splits = counts.splits;
  stats.collapses = counts.collapses;
  stats.flips = counts.flips;
  stats.relaxations = counts.relaxations;
  stats.rejected_ops = counts.rejected;
  const std::vector<std::uint8_t> frozen = frozen_flags(state);
  stats.frozen_vertices = static_cast<std::size_t>(std::count(frozen.begin(), frozen.end(), 1));
}

remesh_patch_output unchanged_output(const remesh_patch_input& input, remesh_stats stats) {
  remesh_patch_output out;
  out.mesh.positions = input.positions;
  out.mesh.normals = input.normals;
  out.mesh.triangles = input.triangles;
  out.origin.resize(input.positions.size());
  std::iota(out.origin.begin(), out.origin.end(), 0U);
  out.frozen.assign(input.positions.size(), 1);
  out.stats = stats;
  return out;
}

}  // namespace

status check_remesh_options(const remesh_options& o) {
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
  if (!(o.done_edge_ratio_mean >= 0) || !std::isfinite(o.done_edge_ratio_mean) ||
      !(o.done_poor_share >= 0 && o.done_poor_share <= 1)) {
    return invalid("done_edge_ratio_mean must be finite and at least 0, done_poor_share in [0, 1]");
  }
  if (!(o.final_collapse_below >= 0 && o.final_collapse_below < 0.5)) {
    return invalid("final_collapse_below must be in [0, 0.5)");
  }
  if (!(o.chunk_edges >= 16) || !std::isfinite(o.chunk_edges)) return invalid("chunk_edges must be at least 16");
  return status::success();
}

result<remesh_patch_output> remesh_patch(const remesh_patch_input& input, const remesh_patch_context& context,
                                         const gaussian_field& field, const remesh_options& options,
                                         progress_token& progress, bool report_stages) {
  if (status s = check_remesh_options(options); !s) return s;
  remesh_stats stats;
  result<remesh_mesh> built = remesh_mesh::build(input.positions, input.normals, input.triangles, true);
  if (!built) return built.error();
  const remesh_mesh& input_mesh = built.value();
  const auto input_vertices = static_cast<std::uint32_t>(input.positions.size());
  const std::vector<component_topology> input_topology = topology_of(input_mesh);

  // Frozen from the start: the boundary and the caller's list.
  std::vector<std::uint8_t> frozen_input = frozen_flags(input_mesh);
  if (input.frozen.size() == frozen_input.size()) {
    for (std::size_t v = 0; v < frozen_input.size(); ++v) frozen_input[v] |= input.frozen[v];
  }
  const double l = options.target_edge;
  // A whole mesh the caller certifies anyway (remesh_options::unchecked_below_triangles) finds nothing to refuse.
  stats.unchecked = context.triangles.empty() && !context.bounded &&
                    input.triangles.size() < options.unchecked_below_triangles;
  const offending_finder finder =
      stats.unchecked ? [](const remesh_mesh&, const surface_mesh&) { return std::vector<std::uint32_t>{}; }
                      : finder_with(context, input_vertices);

  // Level 2 of remesh.hpp: should a round end unclean, restart from the input with its vertices near the offending
  // triangles frozen, until clean (at worst everything is frozen and the input comes back).
  for (int round = 1; round <= options.max_rounds; ++round) {
    stats.rounds = round;
    remesh_mesh state = input_mesh;
    protect(state, frozen_input);
    verified_stages stages(field, thresholds_for(options), options.max_triangles, progress, finder);
    result<bool> clean = run_round(state, stages, options, progress, report_stages);
    if (!clean) return clean.error();
    stats.field_evaluations += stages.field_evaluations();
    if (clean.value()) {
      surface_mesh out = certificate_view(state);
      // Cannot differ by construction; checked so that a bug never hands out a broken mesh. An unchecked whole mesh
      // is left to its caller's certificate, which tests all this (closed, edge- and vertex-manifold, oriented,
      // every vertex used) and runs the pass again, checked, should it fail.
      if (!stats.unchecked && !remesh_mesh::build(out.positions, out.normals, out.triangles, true).ok()) break;
      // build() numbers vertices afresh: compare topologies keyed by the input's indices.
      std::vector<std::uint32_t> origin(state.vertex_slots());
      for (std::uint32_t v = 0; v < state.vertex_slots(); ++v) origin[v] = state.origin(v);
      if (topology_of(state) != input_topology) break;
      record_operations(stages, state, stats);
      remesh_patch_output result_patch;
      result_patch.mesh = std::move(out);
      result_patch.origin = std::move(origin);
      result_patch.frozen = frozen_flags(state);
      result_patch.stats = stats;
      return result_patch;
    }
    const check_failure& failure = stages.last_failure();
    const double radius = options.freeze_radius * l * std::ldexp(1.0, round - 1);
    if (freeze_near(input.positions, failure.mesh.positions, failure.mesh.triangles, failure.offending, radius,
                    frozen_input) == 0) {
      break;
    }
  }
  // No clean result: keep the (valid) input.
  stats.input_returned = true;
  stats.frozen_vertices = static_cast<std::size_t>(std::count(frozen_input.begin(), frozen_input.end(), 1));
  return unchanged_output(input, stats);
}

}  // namespace tracemesh::detail
