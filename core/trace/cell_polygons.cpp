#include "core/trace/cell_polygons.hpp"

#include <algorithm>
#include <cmath>

#include "core/analysis/triangle_intersection.hpp"
#include "core/trace/loop_triangulation.hpp"

namespace tracemesh {
namespace {

/// A Steiner point must lie this far (× h̃) inside the cell's cross-section, off its walls, so that its fan stays
/// admissible (method.md §7.8).
constexpr double steiner_wall_margin = 1e-3;

/// One wall of a cell: its strip, whether the cell reads the strip's arcs backwards, and its bit.
struct cell_wall_strip {
  strip_id strip;
  bool reversed;
  std::uint8_t bit;
};

std::array<cell_wall_strip, 4> walls_of(const cell_id& c) {
  return {{{{0, c.j, c.k}, true, wall_z_low},
           {{0, c.j, c.k + 1}, false, wall_z_high},
           {{1, c.j, c.k}, false, wall_y_low},
           {{1, c.j + 1, c.k}, true, wall_y_high}}};
}

/// One loop vertex with its number in the mesh.
struct numbered_vertex {
  std::uint32_t id;
  loop_vertex vertex;
};

/// An arc of the cell in the direction the cell walks it.
using cell_arc = std::vector<numbered_vertex>;

std::uint8_t planes_of_line(const line_id& line, const cell_id& c) {
  std::uint8_t bits = 0;
  if (line.j == c.j) bits |= wall_y_low;
  if (line.j == c.j + 1) bits |= wall_y_high;
  if (line.k == c.k) bits |= wall_z_low;
  if (line.k == c.k + 1) bits |= wall_z_high;
  return bits;
}

/// The root at one end of an arc of `strip`, numbered; false when the line does not hold it.
bool root_vertex(const traced_surface& surface, const strip_id& strip, const arc_end& end, const cell_id& cell,
                 numbered_vertex& out) {
  const line_id line = end.side == 0 ? strip.low_line() : strip.high_line();
  const std::size_t n = surface.lines.find(line);
  if (n == surface.lines.line_count()) return false;
  const std::span<const line_point> roots = surface.lines.roots(n);
  const std::int64_t r = surface.lines.match(roots, end.x);
  if (r < 0) return false;
  const double h = surface.spacing;
  const line_point& root = roots[static_cast<std::size_t>(r)];
  out.id = surface.lines.global_index(n, static_cast<std::size_t>(r));
  out.vertex.position = {root.x, static_cast<double>(line.j) * h, static_cast<double>(line.k) * h};
  out.vertex.normal = normalized(-root.gradient);
  out.vertex.planes = planes_of_line(line, cell);
  return true;
}

/// The arcs of the cell's four walls, each in the cell's direction; false when an arc end is not on its line.
bool gather_arcs(const traced_surface& surface, const cell_id& cell, std::vector<cell_arc>& arcs) {
  for (const cell_wall_strip& wall : walls_of(cell)) {
    const std::size_t s = surface.find_strip(wall.strip);
    if (s == surface.strips.size()) continue;
    const strip_trace& trace = surface.traces[s];
    for (const strip_arc& arc : trace.arcs) {
      cell_arc vertices;
      numbered_vertex end;
      if (!root_vertex(surface, wall.strip, arc.start, cell, end)) return false;
      vertices.push_back(end);
      for (std::uint32_t n = 0; n < arc.interior_count; ++n) {
        const surface_sample& p = trace.interior[arc.first_interior + n];
        vertices.push_back({surface.interior_first[s] + arc.first_interior + n,
                            {p.position, normalized(-p.gradient), wall.bit}});
      }
      if (!root_vertex(surface, wall.strip, arc.end, cell, end)) return false;
      vertices.push_back(end);
      if (wall.reversed) std::reverse(vertices.begin(), vertices.end());
      arcs.push_back(std::move(vertices));
    }
  }
  return true;
}

/// Chains the arcs into closed loops (Algorithm 2: from a point, follow the arcs from wall to wall until the walk
/// returns). False when some point starts or ends two arcs of the cell, or an arc leads nowhere.
bool chain_loops(const std::vector<cell_arc>& arcs, std::vector<std::vector<numbered_vertex>>& loops) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> starts, ends;  // (vertex, arc)
  for (std::uint32_t a = 0; a < arcs.size(); ++a) {
    starts.emplace_back(arcs[a].front().id, a);
    ends.emplace_back(arcs[a].back().id, a);
  }
  std::sort(starts.begin(), starts.end());
  std::sort(ends.begin(), ends.end());
  for (std::size_t n = 0; n < starts.size(); ++n) {
    if (starts[n].first != ends[n].first) return false;  // the same set of points must start and end arcs, once each
    if (n > 0 && starts[n].first == starts[n - 1].first) return false;
  }
  std::vector<char> used(arcs.size(), 0);
  for (std::uint32_t first = 0; first < arcs.size(); ++first) {
    if (used[first]) continue;
    std::vector<numbered_vertex> loop;
    std::uint32_t a = first;
    while (!used[a]) {
      used[a] = 1;
      loop.insert(loop.end(), arcs[a].begin(), arcs[a].end() - 1);
      const auto next = std::lower_bound(starts.begin(), starts.end(), std::make_pair(arcs[a].back().id, 0u));
      a = next->second;
    }
    if (a != first) return false;  // walked into a loop that does not come back to its start
    loops.push_back(std::move(loop));
  }
  return true;
}

/// Fallback for a loop the admissible triangulation cannot close: a fan around its centroid moved onto the surface,
/// kept strictly inside the cell (counted in trace_stats::fallback_loops).
bool fan_around_steiner_point(const gaussian_field& field, const std::vector<numbered_vertex>& loop,
                              const cell_id& cell, double h, cell_mesh& out) {
  vec3 centre;
  for (const numbered_vertex& v : loop) centre += v.vertex.position;
  centre = centre / static_cast<double>(loop.size());
  if (!field.project_to_surface(centre, h)) return false;
  out.evaluations += 8;
  const double margin = steiner_wall_margin * h;
  const double y0 = static_cast<double>(cell.j) * h, z0 = static_cast<double>(cell.k) * h;
  if (!(centre.y > y0 + margin && centre.y < y0 + h - margin && centre.z > z0 + margin && centre.z < z0 + h - margin)) {
    return false;
  }
  vec3 gradient;
  field.value_and_gradient(centre, gradient);
  const vec3 normal = normalized(-gradient);
  for (std::size_t n = 0; n < loop.size(); ++n) {
    const vec3& a = loop[n].vertex.position;
    const vec3& b = loop[(n + 1) % loop.size()].vertex.position;
    const vec3 face = cross(b - a, centre - a);
    if (!(dot(face, normal + loop[n].vertex.normal + loop[(n + 1) % loop.size()].vertex.normal) > 0)) return false;
  }
  const std::uint32_t steiner = steiner_vertex + static_cast<std::uint32_t>(out.steiner.size());
  out.steiner.push_back({centre, gradient, false});
  for (std::size_t n = 0; n < loop.size(); ++n) {
    out.triangles.push_back({loop[n].id, loop[(n + 1) % loop.size()].id, steiner});
  }
  ++out.fallback_loops;
  return true;
}

/// Triangulates one loop by the admissible maximin triangulation, or by the fallback fan.
bool triangulate(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell, double h,
                 cell_mesh& out) {
  std::vector<loop_vertex> vertices(loop.size());
  for (std::size_t n = 0; n < loop.size(); ++n) vertices[n] = loop[n].vertex;
  std::vector<std::array<std::uint32_t, 3>> local;
  loop_triangulation_stats stats;
  if (loop.size() >= 3 && triangulate_loop(vertices, local, stats)) {
    for (const auto& t : local) out.triangles.push_back({loop[t[0]].id, loop[t[1]].id, loop[t[2]].id});
    return true;
  }
  return fan_around_steiner_point(field, loop, cell, h, out);
}

/// Positions of the cell's vertices, by mesh number or Steiner number.
class cell_positions {
 public:
  cell_positions(const std::vector<std::vector<numbered_vertex>>& loops, const cell_mesh& mesh) {
    for (const auto& loop : loops) {
      for (const numbered_vertex& v : loop) entries_.emplace_back(v.id, v.vertex.position);
    }
    for (std::size_t n = 0; n < mesh.steiner.size(); ++n) {
      entries_.emplace_back(steiner_vertex + static_cast<std::uint32_t>(n), mesh.steiner[n].position);
    }
    std::sort(entries_.begin(), entries_.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  }
  /// The triangles with local vertex numbers, and the local positions.
  void localise(const std::vector<std::array<std::uint32_t, 3>>& triangles, std::vector<vec3>& positions,
                std::vector<std::array<std::uint32_t, 3>>& local) const {
    positions.clear();
    for (const auto& e : entries_) positions.push_back(e.second);
    local.clear();
    for (const auto& t : triangles) {
      std::array<std::uint32_t, 3> l{};
      for (int c = 0; c < 3; ++c) {
        const auto it = std::lower_bound(entries_.begin(), entries_.end(), t[c],
                                         [](const auto& e, std::uint32_t id) { return e.first < id; });
        l[c] = static_cast<std::uint32_t>(it - entries_.begin());
      }
      local.push_back(l);
    }
  }

 private:
  std::vector<std::pair<std::uint32_t, vec3>> entries_;
};

/// True when two triangles of the cell intersect (exact test: method.md §7.8 — with admissible triangulations,
/// triangles of different cells meet only along shared arcs, so this per-cell test covers the whole mesh).
bool cell_self_intersects(const std::vector<std::vector<numbered_vertex>>& loops, const cell_mesh& mesh) {
  if (mesh.triangles.size() < 2) return false;
  std::vector<vec3> positions;
  std::vector<std::array<std::uint32_t, 3>> local;
  cell_positions(loops, mesh).localise(mesh.triangles, positions, local);
  for (std::size_t a = 0; a < local.size(); ++a) {
    for (std::size_t b = a + 1; b < local.size(); ++b) {
      if (detail::mesh_triangles_intersect(positions, local[a], local[b])) return true;
    }
  }
  return false;
}

}  // namespace

std::size_t traced_surface::find_strip(const strip_id& strip) const {
  const auto it = std::lower_bound(strips.begin(), strips.end(), strip);
  return it != strips.end() && *it == strip ? static_cast<std::size_t>(it - strips.begin()) : strips.size();
}

cell_mesh mesh_cell(const gaussian_field& field, const traced_surface& surface, const cell_id& cell) {
  cell_mesh out;
  std::vector<cell_arc> arcs;
  std::vector<std::vector<numbered_vertex>> loops;
  if (!gather_arcs(surface, cell, arcs) || !chain_loops(arcs, loops)) {
    out.closed = false;
    return out;
  }
  out.loops = loops.size();
  for (const auto& loop : loops) {
    if (!triangulate(field, loop, cell, surface.spacing, out)) out.closed = false;
  }
  if (out.closed && cell_self_intersects(loops, out)) {
    // Second chance: every loop of the cell as a fan around its own surface point.
    out.triangles.clear();
    out.steiner.clear();
    out.fallback_loops = 0;
    for (const auto& loop : loops) {
      if (!fan_around_steiner_point(field, loop, cell, surface.spacing, out)) out.closed = false;
    }
    out.intersecting = out.closed && cell_self_intersects(loops, out);
  }
  return out;
}

}  // namespace tracemesh
