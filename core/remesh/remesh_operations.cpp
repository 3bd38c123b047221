#include "core/remesh/remesh_operations.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/remesh/remesh_geometry.hpp"

namespace tracemesh::detail {
namespace {

/// Below this shape quality a triangle's normal is dominated by position noise (marching-tetrahedra slivers): it
/// is not used to decide whether its replacement flips.
constexpr double meaningful_normal_quality = 0.05;
/// Cancellation is polled every this many candidate edges.
constexpr std::size_t poll_interval = 4096;
constexpr int target_valence = 6;
/// Splits and collapses may leave their worst triangle at this fraction of the worst one they replace (when under
/// the quality floor): dissolving a cluster of slivers makes some neighbouring thin triangle marginally thinner.
constexpr double topological_quality_slack = 0.5;
/// Relaxation leaves a vertex whose move would be shorter than this fraction of the collapse length (about L).
constexpr double settled_move = 0.05;
/// How much worse (in cosine) a triangle's agreement with its corner normals may get when it barely moves.
constexpr double small_change_agreement_slack = 0.2;
/// Å: the new vertex of a split or of a collapse onto the midpoint is projected to this first-order distance from
/// the surface only, not to surface_tolerance: relaxation moves it again with single Newton steps, and
/// settle_vertices() projects every vertex an edit placed to surface_tolerance before the round is checked.
constexpr double edit_surface_tolerance = 1e-2;

bool contains(const std::vector<std::uint32_t>& list, std::uint32_t value) {
  return std::find(list.begin(), list.end(), value) != list.end();
}

}  // namespace

remesh_operations::remesh_operations(remesh_mesh& mesh, const gaussian_field& field,
                                     const remesh_thresholds& thresholds, const progress_token& progress)
    : mesh_(mesh),
      field_(field),
      thresholds_(thresholds),
      progress_(progress),
      settled_move2_(std::pow(settled_move * thresholds.collapse_below, 2)) {}

bool remesh_operations::visits_edge(std::uint32_t h) const {
  // Boundary half-edges (patches only) have no opposite: their edge is never edited.
  const std::uint32_t o = mesh_.opposite(h);
  return !mesh_.face_removed(remesh_mesh::face_of(h)) && o != no_index && o > h;
}

bool remesh_operations::stop_requested(std::size_t step) const {
  return step % poll_interval == 0 && progress_.cancelled();
}

bool remesh_operations::project(vec3& p, vec3& n, double tolerance) const {
  std::size_t evaluations = 0;
  const bool projected = project_onto_surface(field_, p, n, thresholds_.max_move, tolerance, &evaluations);
  field_evaluations_.fetch_add(evaluations, std::memory_order_relaxed);
  return projected;
}

operation_counts remesh_operations::counts() const {
  operation_counts c = counts_;
  c.field_evaluations = field_evaluations_.load(std::memory_order_relaxed);
  return c;
}

bool remesh_operations::project_new_vertex(vec3& p, vec3& n) const {
  return project(p, n, std::max(edit_surface_tolerance, thresholds_.surface_tolerance));
}

// --- acceptance of new triangles ------------------------------------------------------------------------------

remesh_operations::oriented_triangle remesh_operations::triangle_of(std::uint32_t h) const {
  const std::uint32_t a = mesh_.from(h), b = mesh_.to(h), c = mesh_.apex(h);
  return {{mesh_.position(a), mesh_.position(b), mesh_.position(c)},
          {mesh_.normal(a), mesh_.normal(b), mesh_.normal(c)}};
}

remesh_operations::triangle_shape remesh_operations::shape_of(const oriented_triangle& t) {
  const vec3 area = area_vector(t.p[0], t.p[1], t.p[2]);
  const double edges = squared_norm(t.p[1] - t.p[0]) + squared_norm(t.p[2] - t.p[1]) + squared_norm(t.p[0] - t.p[2]);
  const double quality = edges > 0 ? 2 * std::sqrt(3.0) * norm(area) / edges : 0;  // as triangle_quality
  const vec3 unit = normalized(area);
  const double c0 = dot(area, t.n[0]), c1 = dot(area, t.n[1]), c2 = dot(area, t.n[2]);
  return {quality, unit, std::min({dot(unit, t.n[0]), dot(unit, t.n[1]), dot(unit, t.n[2])}),
          c0 < 0 && c1 < 0 && c2 < 0};
}

remesh_operations::replaced_triangle remesh_operations::replaced(const triangle_shape& t, double worst_quality) {
  return {worst_quality, t.agreement, t.quality >= meaningful_normal_quality ? t.unit_normal : vec3{}};
}

bool remesh_operations::acceptable(const triangle_shape& t, const replaced_triangle& old, bool small_change) const {
  const double q = t.quality;
  if (!(q >= thresholds_.hard_quality_floor) || q < std::min(thresholds_.quality_floor, old.quality)) return false;
  // Never a fold, whatever the slack below allows: a triangle against all three corner normals fails the
  // certificate, and the slack (small moves, slivers, a replaced triangle already leaning away) could let one in.
  if (t.folded) return false;
  // Face the way the surface does at every corner (checked at the vertices, where the field normal is exact and
  // known, rather than at the off-surface centroid), or at least no worse than the triangle replaced where the
  // surface bends too much within one triangle for that; then never beyond 90°, which is how folds start. Slivers
  // (whose normal means little) may just be no worse, and triangles that barely move a little worse: dissolving a
  // cluster of slivers or a tiny edge in a tight fold goes through such triangles.
  const double no_worse = std::min(thresholds_.min_normal_cosine, old.agreement);
  double required = std::max(no_worse, 0.0);
  if (small_change) {
    required = no_worse - small_change_agreement_slack;
  } else if (q < meaningful_normal_quality) {
    required = no_worse;
  }
  if (t.agreement < required) return false;
  return dot(t.unit_normal, old.normal) >= 0;
}

// --- split ------------------------------------------------------------------------------------------------------

bool remesh_operations::split_long_edges() {
  // One sweep; new half-edges are appended and visited in the same sweep. An edge refused now is tried again in the
  // next iteration (repeating the sweep until nothing changes gains few splits).
  const double limit2 = thresholds_.split_above * thresholds_.split_above;
  for (std::uint32_t h = 0; h < mesh_.halfedge_slots(); ++h) {
    if (stop_requested(h)) return false;
    if (!visits_edge(h)) continue;
    if (squared_norm(mesh_.position(mesh_.to(h)) - mesh_.position(mesh_.from(h))) <= limit2) continue;
    if (!try_split(h)) ++counts_.rejected;
  }
  return true;
}

bool remesh_operations::try_split(std::uint32_t h) {
  const std::uint32_t o = mesh_.opposite(h);
  const std::uint32_t a = mesh_.from(h), b = mesh_.to(h), c = mesh_.apex(h), d = mesh_.apex(o);
  for (const std::uint32_t v : {a, b, c, d}) {
    if (mesh_.protection(v) == vertex_protection::frozen) return false;
  }
  if (c == d) return false;
  vec3 p = (mesh_.position(a) + mesh_.position(b)) * 0.5, n;
  if (!project_new_vertex(p, n)) return false;

  // (a, b, c) becomes (a, p, c) + (p, b, c); (b, a, d) becomes (b, p, d) + (p, a, d).
  const oriented_triangle abc = triangle_of(h), bad = triangle_of(o);
  const triangle_shape abc_shape = shape_of(abc), bad_shape = shape_of(bad);
  const double worst = topological_quality_slack * std::min(abc_shape.quality, bad_shape.quality);
  const replaced_triangle old_abc = replaced(abc_shape, worst), old_bad = replaced(bad_shape, worst);
  const auto with_midpoint = [&](oriented_triangle t, int corner) {
    t.p[corner] = p;
    t.n[corner] = n;
    return shape_of(t);
  };
  if (!acceptable(with_midpoint(abc, 1), old_abc) || !acceptable(with_midpoint(abc, 0), old_abc) ||
      !acceptable(with_midpoint(bad, 1), old_bad) || !acceptable(with_midpoint(bad, 0), old_bad)) {
    return false;
  }
  mesh_.split_edge(h, p, n);
  ++counts_.splits;
  return true;
}

// --- collapse ---------------------------------------------------------------------------------------------------

bool remesh_operations::collapse_short_edges(double shorter_than) {
  // One sweep, as for splits: repeated sweeps try many more edges for few more collapses, most of which the next
  // iteration makes anyway (docs/method.md).
  const double limit2 = shorter_than * shorter_than;
  for (std::uint32_t h = 0; h < mesh_.halfedge_slots(); ++h) {
    if (stop_requested(h)) return false;
    if (!visits_edge(h)) continue;
    const std::uint32_t a = mesh_.from(h), b = mesh_.to(h);
    if (squared_norm(mesh_.position(b) - mesh_.position(a)) >= limit2) continue;
    if (mesh_.protection(a) != vertex_protection::free || mesh_.protection(b) != vertex_protection::free) continue;
    if (!try_collapse(h)) ++counts_.rejected;
  }
  return true;
}

bool remesh_operations::try_collapse(std::uint32_t h) {
  const std::uint32_t o = mesh_.opposite(h);
  const std::uint32_t a = mesh_.from(h), b = mesh_.to(h), c = mesh_.apex(h), d = mesh_.apex(o);
  if (c == d) return false;
  // Topology: the merged vertex keeps valence ≥ 3, c and d keep ≥ 3, and a and b share no neighbour but c and d
  // (the link condition: otherwise the collapse would pinch the surface).
  mesh_.one_ring(a, ring_a_);
  mesh_.one_ring(b, ring_b_);
  if (ring_a_.size() + ring_b_.size() < 7) return false;
  if (mesh_.valence(c) <= 3 || mesh_.valence(d) <= 3) return false;
  int common = 0;
  for (const std::uint32_t x : ring_a_) common += contains(ring_b_, x);
  if (common != 2) return false;

  const std::uint32_t f0 = remesh_mesh::face_of(h), f1 = remesh_mesh::face_of(o);
  const vec3 &pa = mesh_.position(a), &pb = mesh_.position(b);
  const vec3 &na = mesh_.normal(a), &nb = mesh_.normal(b);
  const double keep_a = collapse_outcome(a, pa, na, b, f0, f1, ring_b_);
  const double keep_b = collapse_outcome(b, pb, nb, a, f0, f1, ring_a_);
  if (keep_a >= 0 || keep_b >= 0) {
    if (keep_a >= keep_b) {
      mesh_.collapse_edge(h, pa, na);
    } else {
      mesh_.collapse_edge(o, pb, nb);
    }
    ++counts_.collapses;
    return true;
  }
  // Neither end point will do: try the midpoint (it moves both ends, so both fans are checked). Its projection
  // costs field evaluations, so first check the unprojected midpoint with the mean normal: it is within the
  // sagitta of the projected one, and most refusals (edge length, shape) show already.
  vec3 p = (pa + pb) * 0.5, n = normalized(na + nb);
  const auto midpoint_acceptable = [&] {
    return collapse_outcome(a, p, n, b, f0, f1, ring_b_) >= 0 && collapse_outcome(b, p, n, a, f0, f1, ring_a_) >= 0;
  };
  if (!midpoint_acceptable() || !project_new_vertex(p, n) || !midpoint_acceptable()) return false;
  mesh_.collapse_edge(h, p, n);
  ++counts_.collapses;
  return true;
}

double remesh_operations::collapse_outcome(std::uint32_t kept, const vec3& p, const vec3& n, std::uint32_t removed,
                                           std::uint32_t f0, std::uint32_t f1,
                                           const std::vector<std::uint32_t>& removed_ring) {
  // No new edge longer than the split length (edges that already were wait for the next split sweep).
  const double max_edge2 = thresholds_.max_edge_after_collapse * thresholds_.max_edge_after_collapse;
  for (const std::uint32_t x : removed_ring) {
    if (x == kept || squared_norm(mesh_.position(x) - p) <= max_edge2) continue;
    if (squared_norm(mesh_.position(x) - mesh_.position(removed)) <= max_edge2) return -1;
  }
  // The removed vertex's faces, except the two that vanish, get the kept vertex instead.
  const double tiny2 = thresholds_.tiny_below * thresholds_.tiny_below;
  const bool small_change = squared_norm(p - mesh_.position(removed)) < tiny2;
  double worst = 1;
  fan_shapes_.clear();
  const std::uint32_t start = mesh_.outgoing(removed);
  std::uint32_t g = start;
  do {
    fan_shapes_.push_back(shape_of(triangle_of(g)));
    worst = std::min(worst, topological_quality_slack * fan_shapes_.back().quality);
    g = mesh_.rotate(g);
  } while (g != start);
  double worst_new = 1;
  g = start;
  for (std::size_t k = 0;; ++k) {
    const std::uint32_t f = remesh_mesh::face_of(g);
    if (f != f0 && f != f1) {
      oriented_triangle moved = triangle_of(g);
      moved.p[0] = p;
      moved.n[0] = n;
      const triangle_shape moved_shape = shape_of(moved);
      if (!acceptable(moved_shape, replaced(fan_shapes_[k], worst), small_change)) return -1;
      worst_new = std::min(worst_new, moved_shape.quality);
    }
    g = mesh_.rotate(g);
    if (g == start) break;
  }
  return worst_new;
}

// --- flip -------------------------------------------------------------------------------------------------------

bool remesh_operations::flip_edges_for_valence() {
  std::vector<int> valences(mesh_.vertex_slots(), 0);
  for (std::uint32_t v = 0; v < mesh_.vertex_slots(); ++v) {
    if (!mesh_.vertex_removed(v)) valences[v] = static_cast<int>(mesh_.valence(v));
  }
  for (std::uint32_t h = 0; h < mesh_.halfedge_slots(); ++h) {
    if (stop_requested(h)) return false;
    if (!visits_edge(h)) continue;
    try_flip(h, valences);
  }
  return true;
}

bool remesh_operations::try_flip(std::uint32_t h, std::vector<int>& valences) {
  const std::uint32_t o = mesh_.opposite(h);
  const std::uint32_t a = mesh_.from(h), b = mesh_.to(h), c = mesh_.apex(h), d = mesh_.apex(o);
  const auto deviation = [](int va, int vb, int vc, int vd) {
    const auto sq = [](int x) { return (x - target_valence) * (x - target_valence); };
    return sq(va) + sq(vb) + sq(vc) + sq(vd);
  };
  const int before = deviation(valences[a], valences[b], valences[c], valences[d]);
  const int after = deviation(valences[a] - 1, valences[b] - 1, valences[c] + 1, valences[d] + 1);
  if (after >= before || valences[a] <= 3 || valences[b] <= 3 || c == d) return false;
  for (const std::uint32_t v : {a, b, c, d}) {
    if (mesh_.protection(v) == vertex_protection::frozen) return false;
  }
  if (mesh_.find_halfedge(c, d) != no_index) {
    ++counts_.rejected;
    return false;
  }
  // (a, b, c) and (b, a, d) become (a, d, c) and (d, b, c). Each must match the worse of the old pair, and the
  // two may not fold against each other along c–d.
  const oriented_triangle abc = triangle_of(h), bad = triangle_of(o);
  const oriented_triangle adc{{abc.p[0], bad.p[2], abc.p[2]}, {abc.n[0], bad.n[2], abc.n[2]}};
  const oriented_triangle dbc{{bad.p[2], abc.p[1], abc.p[2]}, {bad.n[2], abc.n[1], abc.n[2]}};
  const triangle_shape abc_shape = shape_of(abc), bad_shape = shape_of(bad);
  const triangle_shape adc_shape = shape_of(adc), dbc_shape = shape_of(dbc);
  const double worst = std::min(abc_shape.quality, bad_shape.quality);
  const double worst_agreement = std::min(abc_shape.agreement, bad_shape.agreement);
  const replaced_triangle against_dbc{worst, worst_agreement, dbc_shape.unit_normal};
  const replaced_triangle against_adc{worst, worst_agreement, adc_shape.unit_normal};
  if (!acceptable(adc_shape, against_dbc) || !acceptable(dbc_shape, against_adc)) {
    ++counts_.rejected;
    return false;
  }
  mesh_.flip_edge(h);
  --valences[a];
  --valences[b];
  ++valences[c];
  ++valences[d];
  ++counts_.flips;
  return true;
}

// --- tangential relaxation -------------------------------------------------------------------------------------

bool remesh_operations::relaxed_position(std::uint32_t v, vec3& position, vec3& normal) const {
  const vec3& p = mesh_.position(v);
  vec3 weighted{};
  double total_area = 0;
  double worst = 1;
  // The fan's shapes, kept for the check of the move (fans are small; a larger one is measured again).
  constexpr std::size_t kept_shapes = 16;
  std::array<triangle_shape, kept_shapes> shapes;
  std::size_t fan_size = 0;
  const std::uint32_t start = mesh_.outgoing(v);
  std::uint32_t g = start;
  do {
    const oriented_triangle t = triangle_of(g);
    const double area = norm(area_vector(t.p[0], t.p[1], t.p[2]));
    weighted += (t.p[0] + t.p[1] + t.p[2]) * (area / 3);
    total_area += area;
    const triangle_shape shape = shape_of(t);
    if (fan_size < kept_shapes) shapes[fan_size] = shape;
    ++fan_size;
    worst = std::min(worst, shape.quality);
    g = mesh_.rotate(g);
  } while (g != start);
  if (!(total_area > 0)) return false;

  const vec3& n = mesh_.normal(v);
  vec3 move = weighted / total_area - p;
  move -= n * dot(n, move);  // stay in the tangent plane; the projection below follows the curvature
  // A vertex already (almost) where its ring wants it stays: its move would cost a field evaluation for nothing.
  if (squared_norm(move) <= settled_move2_) return false;
  vec3 q = p + move, nq;
  field_evaluations_.fetch_add(1, std::memory_order_relaxed);
  if (!newton_step_to_surface(field_, q, nq, thresholds_.max_move)) return false;

  g = start;
  for (std::size_t k = 0;; ++k) {
    oriented_triangle moved = triangle_of(g);
    const triangle_shape old = k < kept_shapes ? shapes[k] : shape_of(moved);
    moved.p[0] = q;
    moved.n[0] = nq;
    if (!acceptable(shape_of(moved), replaced(old, worst))) return false;
    g = mesh_.rotate(g);
    if (g == start) break;
  }
  position = q;
  normal = nq;
  return true;
}

bool remesh_operations::relax_vertices() {
  enum outcome : std::uint8_t { unchanged, moved, refused };
  std::vector<std::uint8_t> outcomes(mesh_.vertex_slots(), unchanged);
  for (const auto& colour : colour_free_vertices(mesh_)) {
    if (progress_.cancelled()) return false;
    // Vertices of one colour are pairwise non-adjacent: each reads only its own 1-ring, which nobody moves now.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, colour.size(), 256), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const std::uint32_t v = colour[i];
        vec3 position, normal;
        if (relaxed_position(v, position, normal)) {
          mesh_.move_vertex(v, position, normal);
          outcomes[v] = moved;
        } else {
          outcomes[v] = refused;
        }
      }
    });
  }
  for (const std::uint8_t o : outcomes) {
    counts_.relaxations += o == moved;
    counts_.rejected += o == refused;
  }
  return true;
}

std::vector<std::uint32_t> remesh_operations::settle_vertices() {
  std::vector<std::uint8_t> failed(mesh_.vertex_slots(), 0);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, mesh_.vertex_slots(), 256), [&](const auto& range) {
    for (std::uint32_t v = range.begin(); v != range.end(); ++v) {
      if (mesh_.vertex_removed(v) || !mesh_.placed(v)) continue;
      vec3 p = mesh_.position(v), n;
      if (project(p, n, thresholds_.surface_tolerance)) {
        mesh_.move_vertex(v, p, n);
      } else {
        failed[v] = 1;
      }
    }
  });
  // The edits checked their triangles with the vertex where they left it, not where this projection puts it: tenths
  // of an Å away after relaxation's single Newton step on a steep field, hundredths after a split's coarse projection,
  // with a turned normal. A triangle accepted nearly edge-on to its corner normals may then face against all three.
  // Every triangle at a placed vertex was unfolded when last edited, so a fold there now is this projection's: its
  // placed corners count as unsettled, and the stage is refused like any other unclean one.
  std::vector<std::uint8_t> folded(mesh_.face_slots(), 0);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, mesh_.face_slots(), 1024), [&](const auto& range) {
    for (std::uint32_t f = range.begin(); f != range.end(); ++f) {
      if (mesh_.face_removed(f)) continue;
      const auto t = mesh_.face(f);
      const bool settled = (mesh_.placed(t[0]) && !failed[t[0]]) || (mesh_.placed(t[1]) && !failed[t[1]]) ||
                           (mesh_.placed(t[2]) && !failed[t[2]]);
      if (!settled) continue;
      folded[f] = shape_of({{mesh_.position(t[0]), mesh_.position(t[1]), mesh_.position(t[2])},
                            {mesh_.normal(t[0]), mesh_.normal(t[1]), mesh_.normal(t[2])}})
                      .folded;
    }
  });
  for (std::uint32_t f = 0; f < folded.size(); ++f) {
    if (!folded[f]) continue;
    for (const std::uint32_t v : mesh_.face(f)) failed[v] |= mesh_.placed(v) ? 1 : 0;
  }
  std::vector<std::uint32_t> unsettled;
  for (std::uint32_t v = 0; v < failed.size(); ++v) {
    if (failed[v]) unsettled.push_back(v);
  }
  return unsettled;
}

std::vector<std::vector<std::uint32_t>> colour_free_vertices(const remesh_mesh& mesh) {
  constexpr std::uint8_t uncoloured = 255;
  std::vector<std::uint8_t> colour(mesh.vertex_slots(), uncoloured);
  std::vector<std::vector<std::uint32_t>> classes;
  std::vector<std::uint32_t> ring;
  std::vector<bool> used;
  for (std::uint32_t v = 0; v < mesh.vertex_slots(); ++v) {
    if (mesh.vertex_removed(v) || mesh.protection(v) != vertex_protection::free) continue;
    mesh.one_ring(v, ring);
    used.assign(classes.size() + 1, false);
    for (const std::uint32_t x : ring) {
      if (colour[x] != uncoloured) used[colour[x]] = true;
    }
    std::size_t c = 0;
    while (used[c]) ++c;
    // Valences stay far below 254 on a remeshed surface; a vertex of huge valence simply does not move.
    if (c >= uncoloured) continue;
    if (c == classes.size()) classes.emplace_back();
    colour[v] = static_cast<std::uint8_t>(c);
    classes[c].push_back(v);
  }
  return classes;
}

}  // namespace tracemesh::detail
