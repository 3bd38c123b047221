#include "core/remesh.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
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

/// Appends the triangles with a corner in `vertices` (sorted) to `triangles`, keeping it sorted and unique.
void add_triangles_at(const triangle_list& all, const std::vector<std::uint32_t>& vertices,
                      std::vector<std::uint32_t>& triangles) {
  if (vertices.empty()) return;
  for (std::uint32_t t = 0; t < all.size(); ++t) {
    for (const std::uint32_t v : all[t]) {
      if (std::binary_search(vertices.begin(), vertices.end(), v)) {
        triangles.push_back(t);
        break;
      }
    }
  }
  std::sort(triangles.begin(), triangles.end());
  triangles.erase(std::unique(triangles.begin(), triangles.end()), triangles.end());
}

/// Sets `frozen` vertices frozen and their other neighbours locked (see vertex_protection).
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

std::vector<std::uint8_t> frozen_flags(const remesh_mesh& mesh) {
  std::vector<std::uint8_t> frozen(mesh.vertex_slots());
  for (std::uint32_t v = 0; v < mesh.vertex_slots(); ++v) frozen[v] = mesh.protection(v) == vertex_protection::frozen;
  return frozen;
}

/// A compacted mesh as the certificate sees it.
surface_mesh certificate_view(const remesh_mesh& mesh) {
  surface_mesh view;
  view.positions = mesh.positions();
  view.normals = mesh.normals();
  view.triangles = mesh.triangles();
  return view;
}

/// The part of the pass between two checks: an iteration of split/collapse/flip/relax, or the final relaxation.
/// Returns false when cancelled.
using stage = std::function<bool(detail::remesh_operations&)>;

/// A failed check: the offending triangles and the mesh they belong to.
struct check_failure {
  surface_mesh mesh;
  std::vector<std::uint32_t> offending;
};

/// Runs the stages of one round, each on a copy of the current state that is kept only when the certificate
/// would accept it (first level of safety: a failure costs one stage, not the round).
class verified_round {
 public:
  verified_round(const gaussian_field& field, const remesh_options& options, progress_token& progress)
      : field_(field), options_(options), thresholds_(thresholds_for(options)), progress_(progress) {}

  /// Remeshes `state` (the input with its protection). On success `state` is clean and settled on the surface;
  /// returns false when even settling alone fails its check (see last_failure()).
  result<bool> run(remesh_mesh& state) {
    const int stages = options_.iterations + 2;
    // Tiny edges first, as a stage of their own: a region frozen later then keeps none of them.
    if (options_.iterations > 0) {
      const auto tiny_edges = [&](detail::remesh_operations& ops) {
        return ops.collapse_short_edges(thresholds_.tiny_below);
      };
      result<bool> done = run_verified(state, tiny_edges, false);
      if (!done) return done;  // a failed stage simply leaves the state as it was
      if (!progress_.report(mesh_stage::refining, 1.0 / stages)) return cancelled();
    }
    for (int iteration = 0; iteration < options_.iterations; ++iteration) {
      const auto one_iteration = [&](detail::remesh_operations& ops) {
        return ops.split_long_edges() && ops.collapse_short_edges(thresholds_.collapse_below) &&
               ops.flip_edges_for_valence() && ops.relax_vertices();
      };
      result<bool> done = run_verified(state, one_iteration, false);
      if (!done) return done;
      if (!progress_.report(mesh_stage::refining, static_cast<double>(iteration + 2) / stages)) return cancelled();
    }
    const auto final_relaxation = [&](detail::remesh_operations& ops) {
      for (int sweep = 0; sweep < options_.final_relaxations; ++sweep) {
        if (!ops.relax_vertices()) return false;
      }
      return true;
    };
    result<bool> settled = run_verified(state, final_relaxation, true);
    if (settled && !settled.value()) {
      // The relaxation could not be made clean: settle the vertices where they are.
      const auto no_operation = [](detail::remesh_operations&) { return true; };
      settled = run_verified(state, no_operation, true);
    }
    return settled;
  }

  const detail::operation_counts& counts() const { return counts_; }
  std::size_t retried_stages() const { return retried_; }
  const check_failure& last_failure() const { return failure_; }

 private:
  static status cancelled() { return {errc::cancelled, "remesh: cancelled"}; }

  /// Runs `run_stage` (then, when `settle`, projects every placed vertex) on copies of `state` until one passes the
  /// check, freezing the vertices of `state` near the offending triangles between tries. Returns whether `state`
  /// advanced; it stays as it was when freezing cannot help.
  result<bool> run_verified(remesh_mesh& state, const stage& run_stage, bool settle) {
    for (int attempt = 0;; ++attempt) {
      remesh_mesh trial = state;
      detail::remesh_operations ops(trial, field_, thresholds_, progress_);
      if (!run_stage(ops)) return cancelled();
      trial.compact();
      if (trial.live_face_count() > options_.max_triangles) {
        return status{errc::limit_exceeded, "remesh: more than max_triangles triangles"};
      }
      const std::vector<std::uint32_t> unsettled = settle ? ops.settle_vertices() : std::vector<std::uint32_t>{};
      failure_.mesh = certificate_view(trial);
      failure_.offending = detail::find_offending_triangles(failure_.mesh);
      add_triangles_at(failure_.mesh.triangles, unsettled, failure_.offending);
      if (failure_.offending.empty()) {
        state = std::move(trial);
        add_counts(ops.counts());
        return true;
      }
      if (attempt == max_stage_retries) return false;
      std::vector<std::uint8_t> frozen = frozen_flags(state);
      const double radius = options_.freeze_radius * options_.target_edge * std::ldexp(1.0, attempt);
      if (freeze_near(state.positions(), failure_.mesh.positions, failure_.mesh.triangles, failure_.offending, radius,
                      frozen) == 0) {
        return false;
      }
      protect(state, frozen);
      ++retried_;
    }
  }

  void add_counts(const detail::operation_counts& c) {
    counts_.splits += c.splits;
    counts_.collapses += c.collapses;
    counts_.flips += c.flips;
    counts_.relaxations += c.relaxations;
    counts_.rejected += c.rejected;
  }

  /// Tries of one stage with growing frozen regions before it is skipped.
  static constexpr int max_stage_retries = 4;

  const gaussian_field& field_;
  const remesh_options& options_;
  const detail::remesh_thresholds thresholds_;
  progress_token& progress_;
  detail::operation_counts counts_;
  std::size_t retried_ = 0;
  check_failure failure_;
};

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
    protect(state, frozen_input);
    verified_round pass(field, options, progress);
    result<bool> clean = pass.run(state);
    if (!clean) return clean.error();
    stats.retried_stages += pass.retried_stages();
    if (clean.value()) {
      surface_mesh out = certificate_view(state);
      // Cannot differ by construction; checked so that a bug never hands out a broken mesh.
      if (component_euler_characteristics(out.positions.size(), out.triangles) != input_topology ||
          !remesh_mesh::build(out.positions, out.normals, out.triangles).ok()) {
        break;
      }
      const detail::operation_counts& counts = pass.counts();
      stats.splits = counts.splits;
      stats.collapses = counts.collapses;
      stats.flips = counts.flips;
      stats.relaxations = counts.relaxations;
      stats.rejected_ops = counts.rejected;
      const std::vector<std::uint8_t> frozen = frozen_flags(state);
      stats.frozen_vertices = static_cast<std::size_t>(std::count(frozen.begin(), frozen.end(), 1));
      write_mesh(mesh, field, std::move(out.positions), std::move(out.normals), std::move(out.triangles));
      return stats;
    }
    const check_failure& failure = pass.last_failure();
    const double radius = options.freeze_radius * l * std::ldexp(1.0, round - 1);
    if (freeze_near(mesh.positions, failure.mesh.positions, failure.mesh.triangles, failure.offending, radius,
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
