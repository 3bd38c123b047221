#include "core/trace/cell_polygons.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "core/analysis/triangle_intersection.hpp"
#include "core/trace/loop_triangulation.hpp"

namespace tracemesh {
namespace {

/// A Steiner point must lie this far (× h̃) inside the cell's cross-section, off its walls, so that its fan stays
/// admissible (docs/method.md#the-admissibility-rule).
constexpr double steiner_wall_margin = 1e-3;
/// A fan triangle's area must be at least this × its longest edge² (the certificate's degeneracy rule is 1e-12).
constexpr double steiner_min_area_ratio = 1e-9;

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
using triangle_list = std::vector<std::array<std::uint32_t, 3>>;

std::vector<loop_vertex> vertices_of(const std::vector<numbered_vertex>& loop) {
  std::vector<loop_vertex> out;
  for (const numbered_vertex& v : loop) out.push_back(v.vertex);
  return out;
}

/// `local` (indices into `loop`) in the mesh's vertex numbers, appended to `out`.
void number_triangles(const std::vector<numbered_vertex>& loop, const triangle_list& local, triangle_list& out) {
  for (const auto& t : local) out.push_back({loop[t[0]].id, loop[t[1]].id, loop[t[2]].id});
}

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

/// How a loop is triangulated, in order of preference; all but the first are fallbacks (trace_stats::fallback_loops).
enum class loop_strategy {
  admissible,          ///< the admissible maximin triangulation (docs/method.md#the-admissibility-rule)
  admissible_flat,     ///< the admissible triangulation whose faces agree best with −∇φ (it folds least)
  steiner_fan,         ///< a fan around one new point of the surface inside the cell, faces agreeing with −∇φ
  /// The admissible triangulation without the rule that faces agree with the normals, but for its floor: no face
  /// against all three corners' normals (a fold; loop_triangulation.hpp rule 2). So are the next two.
  admissible_relaxed,
  flat_relaxed,        ///< the flattest admissible triangulation without that rule
  steiner_fan_relaxed, ///< the fan without that rule
  /// Without the admissibility rule either (walls ignored): for a sheet that lies almost in a wall, whose
  /// admissible triangles would have to fold across the cell. Faces in a wall are then possible; the cell's own
  /// test still guards against its other loops, and give_chords_to_one_cell (trace_mesher.cpp) against a neighbour
  /// doing the same.
  unrestricted,
  /// The loop cut into ears in its own best plane (triangulate_loop_in_its_plane), no rule on walls or normals: for
  /// a loop that doubles back on itself in a wall (a hairpin of the contour where it passes a pinch at a sharp
  /// kernel), whose every other triangulation folds over itself. It makes no fold either.
  in_its_plane,
  /// The loop cut in two at its pinch (split_at_pinch): where the surface in the cell narrows to a neck thinner than
  /// the loop's vertices can span (a sheet nearly touching a line, or lying almost in a wall), a point of the surface
  /// at the neck joins two vertices across it, and each half is triangulated on its own, without new vertices.
  split_at_pinch,
  none,                ///< nothing worked: the mesh cannot close here
  /// Not a disk: the loop and a partner loop bound one tube of surface inside the cell, meshed by the band between
  /// them (pair_tube_loops). Set only after every strategy above failed; never moved on by resolve_intersections.
  tube_band,
  tube_partner,        ///< the other loop of a tube_band: its edges are in that band, it has no triangles of its own
  /// Cut into several pieces at pinches (split_at_pinches), when neither a disk nor a tube band closes the loop.
  split_at_pinches,
};
constexpr loop_strategy next(loop_strategy s) { return static_cast<loop_strategy>(static_cast<int>(s) + 1); }

/// One loop's triangles; vertex numbers ≥ steiner_vertex are this loop's own Steiner points.
struct loop_mesh {
  loop_strategy strategy = loop_strategy::none;
  triangle_list triangles;
  std::vector<surface_sample> steiner;
};

/// Where φ crosses t0 on the line centre + t·direction, t ∈ [t_lo, t_hi] (bisection to 1e-12·h); false without a
/// sign change at the ends.
bool crossing_on_segment(const gaussian_field& field, const vec3& centre, const vec3& direction, double t_lo,
                         double t_hi, double h, surface_sample& out, std::size_t& evaluations) {
  const auto residual = [&](double t) {
    ++evaluations;
    return field.value(centre + t * direction) - field.t0();
  };
  double f_lo = residual(t_lo);
  const double f_hi = residual(t_hi);
  if (!(f_lo * f_hi < 0)) return false;
  for (int iteration = 0; iteration < 60 && t_hi - t_lo > 1e-12 * h; ++iteration) {
    const double mid = 0.5 * (t_lo + t_hi);
    const double f_mid = residual(mid);
    if ((f_mid < 0) == (f_lo < 0)) {
      t_lo = mid;
      f_lo = f_mid;
    } else {
      t_hi = mid;
    }
  }
  out.position = centre + (0.5 * (t_lo + t_hi)) * direction;
  field.value_and_gradient(out.position, out.gradient);
  ++evaluations;
  out.extreme = false;
  return true;
}

/// A point of the surface inside the cell for a fan: on a line through the loop's centroid, clipped to the cell's
/// cross-section less a margin, where φ crosses t0. The patch the loop bounds lies in the cell, so a line through
/// its middle meets it; lines along the loop's mean normal, then along x, y and z are tried in turn.
bool steiner_point(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell,
                   double h, const vec3& centre, surface_sample& out, std::size_t& evaluations) {
  vec3 mean_normal;
  for (const numbered_vertex& v : loop) mean_normal += v.vertex.normal;
  const double margin = steiner_wall_margin * h;
  const double lo[2] = {static_cast<double>(cell.j) * h + margin, static_cast<double>(cell.k) * h + margin};
  const double hi[2] = {lo[0] + h - 2 * margin, lo[1] + h - 2 * margin};
  const auto inside = [&](const vec3& p) { return p.y > lo[0] && p.y < hi[0] && p.z > lo[1] && p.z < hi[1]; };
  if (!inside(centre)) return false;
  // First the nearest point of the surface (Newton along ∇φ), when it stays in the cell.
  vec3 projected = centre;
  evaluations += 8;
  if (field.project_to_surface(projected, h) && inside(projected)) {
    out.position = projected;
    field.value_and_gradient(projected, out.gradient);
    out.extreme = false;
    return true;
  }
  for (const vec3& axis : {normalized(mean_normal), vec3{1, 0, 0}, vec3{0, 1, 0}, vec3{0, 0, 1}}) {
    if (squared_norm(axis) == 0) continue;
    double t_lo = -h, t_hi = h;  // the part of the line inside the cross-section (y, z), within ±h
    for (int a = 0; a < 2; ++a) {
      const double c = a == 0 ? centre.y : centre.z, d = a == 0 ? axis.y : axis.z;
      if (d == 0) continue;
      const double t0 = (lo[a] - c) / d, t1 = (hi[a] - c) / d;
      t_lo = std::max(t_lo, std::min(t0, t1));
      t_hi = std::min(t_hi, std::max(t0, t1));
    }
    // The patch may cross the line twice: look for the sign change nearest the centroid among samples.
    constexpr int samples = 16;
    double best_t0 = 0, best_t1 = 0, best_distance = std::numeric_limits<double>::infinity();
    double previous_t = t_lo, previous_f = field.value(centre + t_lo * axis) - field.t0();
    for (int n = 1; n <= samples; ++n) {
      const double t = t_lo + (t_hi - t_lo) * n / samples;
      const double f = field.value(centre + t * axis) - field.t0();
      if (previous_f * f < 0 && std::min(std::abs(previous_t), std::abs(t)) < best_distance) {
        best_distance = std::min(std::abs(previous_t), std::abs(t));
        best_t0 = previous_t;
        best_t1 = t;
      }
      previous_t = t;
      previous_f = f;
    }
    evaluations += samples + 1;
    if (best_t0 != best_t1 && crossing_on_segment(field, centre, axis, best_t0, best_t1, h, out, evaluations)) {
      return true;
    }
  }
  return false;
}

/// A fan around a Steiner point (steiner_point); with check_orientation, every face must agree with the normals.
/// Where a fan's centre is looked for: the loop's centroid, the point of the cell's centre line at the same x,
/// and halfway between them (a patch that hugs a wall may be missed from one and met from another).
std::array<vec3, 3> steiner_origins(const std::vector<numbered_vertex>& loop, const cell_id& cell, double h) {
  vec3 centroid;
  for (const numbered_vertex& v : loop) centroid += v.vertex.position;
  centroid = centroid / static_cast<double>(loop.size());
  const vec3 axis{centroid.x, (static_cast<double>(cell.j) + 0.5) * h, (static_cast<double>(cell.k) + 0.5) * h};
  return {centroid, 0.5 * (centroid + axis), axis};
}

/// Whether two of `triangles` (vertex numbers of `loop`, whose Steiner points steiner_vertex + m are steiner[m])
/// intersect (mesh_triangles_intersect: triangles that share a vertex or an edge may only touch there).
bool pieces_meet(const std::vector<numbered_vertex>& loop, const std::vector<surface_sample>& steiner,
                 const triangle_list& triangles) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> index;
  std::vector<vec3> positions;
  for (const numbered_vertex& v : loop) {
    if (v.id >= steiner_vertex) continue;
    index.emplace_back(v.id, static_cast<std::uint32_t>(positions.size()));
    positions.push_back(v.vertex.position);
  }
  for (std::size_t m = 0; m < steiner.size(); ++m) {
    index.emplace_back(steiner_vertex + static_cast<std::uint32_t>(m), static_cast<std::uint32_t>(positions.size()));
    positions.push_back(steiner[m].position);
  }
  std::sort(index.begin(), index.end());
  triangle_list local;
  for (const auto& t : triangles) {
    std::array<std::uint32_t, 3> c{};
    for (int i = 0; i < 3; ++i) c[i] = std::lower_bound(index.begin(), index.end(), std::make_pair(t[i], 0u))->second;
    local.push_back(c);
  }
  for (std::size_t a = 0; a < local.size(); ++a) {
    for (std::size_t b = a + 1; b < local.size(); ++b) {
      if (detail::mesh_triangles_intersect(positions, local[a], local[b])) return true;
    }
  }
  return false;
}

/// Whether the fan around `centre` has no degenerate triangle, none facing against the normals at all three corners
/// (a fold, which the certificate refuses) and, with check_orientation, every one agreeing with the normals.
bool fan_faces_valid(const std::vector<numbered_vertex>& loop, const surface_sample& centre, bool check_orientation) {
  const vec3 normal = normalized(-centre.gradient);
  for (std::size_t n = 0; n < loop.size(); ++n) {
    const loop_vertex &a = loop[n].vertex, &b = loop[(n + 1) % loop.size()].vertex;
    const vec3 face = cross(b.position - a.position, centre.position - a.position);
    const double longest2 = std::max({squared_norm(b.position - a.position), squared_norm(centre.position - a.position),
                                      squared_norm(centre.position - b.position)});
    if (!(squared_norm(face) > 4 * steiner_min_area_ratio * steiner_min_area_ratio * longest2 * longest2)) {
      return false;  // degenerate
    }
    if (check_orientation && !(dot(face, normal + a.normal + b.normal) > 0)) return false;
    if (dot(face, normal) < 0 && dot(face, a.normal) < 0 && dot(face, b.normal) < 0) return false;  // a fold
  }
  return true;
}

/// A fan around a Steiner point (steiner_point from each of steiner_origins, the first valid fan).
bool fan_around_steiner_point(const gaussian_field& field, const std::vector<numbered_vertex>& loop,
                              const cell_id& cell, double h, bool check_orientation, loop_mesh& out,
                              std::size_t& evaluations) {
  for (const vec3& origin : steiner_origins(loop, cell, h)) {
    surface_sample centre;
    if (!steiner_point(field, loop, cell, h, origin, centre, evaluations)) continue;
    triangle_list fan;
    for (std::size_t n = 0; n < loop.size(); ++n) {
      fan.push_back({loop[n].id, loop[(n + 1) % loop.size()].id, steiner_vertex});
    }
    if (!fan_faces_valid(loop, centre, check_orientation) || pieces_meet(loop, {centre}, fan)) continue;
    out.steiner.push_back(centre);
    out.triangles = std::move(fan);
    return true;
  }
  return false;
}

/// Vertex pairs split_at_pinch tries, the closest first: a loop that reaches this strategy has already failed every
/// other, and this bounds its cost on a long one.
constexpr std::size_t max_pinch_pairs = 64;

/// The strategies a half of a split loop may take: those that add no vertex and keep the wall rule, so that the
/// halves share only the two edges of the cut.
constexpr std::array<loop_strategy, 4> split_half_strategies{loop_strategy::admissible, loop_strategy::admissible_flat,
                                                              loop_strategy::admissible_relaxed,
                                                              loop_strategy::flat_relaxed};

bool triangulate_by(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell,
                    double h, loop_strategy strategy, loop_mesh& out, std::size_t& evaluations,
                    std::uint8_t kept_walls = 0);

/// `p` moved into the cell's cross-section less the Steiner margin (two vertices on one wall have their middle on it).
vec3 into_cross_section(vec3 p, const cell_id& cell, double h) {
  const double margin = 2 * steiner_wall_margin * h;
  const double y = static_cast<double>(cell.j) * h, z = static_cast<double>(cell.k) * h;
  p.y = std::clamp(p.y, y + margin, y + h - margin);
  p.z = std::clamp(p.z, z + margin, z + h - margin);
  return p;
}

/// The half of `loop` from vertex `from` to vertex `to` (loop order), closed through the pinch point.
std::vector<numbered_vertex> loop_half(const std::vector<numbered_vertex>& loop, std::size_t from, std::size_t to,
                                       const numbered_vertex& pinch) {
  std::vector<numbered_vertex> half;
  for (std::size_t n = from; n != to; n = (n + 1) % loop.size()) half.push_back(loop[n]);
  half.push_back(loop[to]);
  half.push_back(pinch);
  return half;
}

/// The first of split_half_strategies that triangulates `half`; false when none does.
bool triangulate_half(const gaussian_field& field, const std::vector<numbered_vertex>& half, const cell_id& cell,
                      double h, loop_mesh& out, std::size_t& evaluations) {
  for (const loop_strategy s : split_half_strategies) {
    if (triangulate_by(field, half, cell, h, s, out, evaluations)) return true;
  }
  return false;
}

/// The pairs (i, j) of `loop`'s vertices that are not neighbours on it, closest first (ties in loop order), at most
/// `limit`; with `off_common_walls`, only pairs that share no wall. The candidate pinches of split_at_pinch and
/// split_piece.
std::vector<std::pair<std::size_t, std::size_t>> closest_vertex_pairs(const std::vector<numbered_vertex>& loop,
                                                                      std::size_t limit, bool off_common_walls) {
  const std::size_t n = loop.size();
  std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> pairs;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // neighbours on the loop
      if (off_common_walls && (loop[i].vertex.planes & loop[j].vertex.planes) != 0) continue;  // a cut in a wall
      pairs.push_back({squared_norm(loop[j].vertex.position - loop[i].vertex.position), {i, j}});
    }
  }
  std::sort(pairs.begin(), pairs.end());
  if (pairs.size() > limit) pairs.resize(limit);
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const auto& [distance2, pair] : pairs) out.push_back(pair);
  return out;
}

/// A loop whose surface piece narrows to a neck (a pinch) bounds a disk that no triangulation of its vertices
/// follows: triangles across the neck must join vertices on both sides of it, and every such triangle stands
/// across the surface (a fold) or lies in a wall. A point of the surface at the neck (steiner_point from the middle
/// of two vertices on either side of it) cuts the disk into two, each bounded by one part of the loop and the two
/// edges to that point, and each is triangulated on its own (split_half_strategies); the two halves walk the cut in
/// opposite directions, so the loop stays closed and oriented. The neck is not known in advance: vertex pairs are
/// tried from the closest (the pinch is where the loop comes back near itself; at most max_pinch_pairs), ties in loop
/// order, and the first split whose halves triangulate without meeting each other is kept.
bool split_at_pinch(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell,
                    double h, loop_mesh& out, std::size_t& evaluations) {
  if (loop.size() < 4) return false;
  for (const auto& [i, j] : closest_vertex_pairs(loop, max_pinch_pairs, false)) {
    surface_sample point;
    const vec3 middle = into_cross_section(0.5 * (loop[i].vertex.position + loop[j].vertex.position), cell, h);
    if (!steiner_point(field, loop, cell, h, middle, point, evaluations)) continue;
    const numbered_vertex pinch{steiner_vertex, {point.position, normalized(-point.gradient), 0}};
    loop_mesh first, second;
    if (!triangulate_half(field, loop_half(loop, i, j, pinch), cell, h, first, evaluations) ||
        !triangulate_half(field, loop_half(loop, j, i, pinch), cell, h, second, evaluations)) {
      continue;
    }
    out.triangles = std::move(first.triangles);
    out.triangles.insert(out.triangles.end(), second.triangles.begin(), second.triangles.end());
    if (pieces_meet(loop, {point}, out.triangles)) {
      out.triangles.clear();
      continue;
    }
    out.steiner.push_back(point);
    return true;
  }
  return false;
}

/// How many times split_at_pinches may cut a piece again, and the vertex pairs it tries per cut (the closest first):
/// bounds on the cost of a loop that no cut closes.
constexpr int max_pinch_depth = 2;
constexpr std::size_t max_pinches_per_cut = 16;

/// A piece of a loop (its vertices may include Steiner points steiner_vertex + m, m < steiner.size()) triangulated
/// without self-intersection: by the first of split_half_strategies whose triangles do not meet, else, while depth
/// allows, cut again at a pinch (split_piece). Appends to `triangles` and `steiner`; false leaves them as they were.
bool triangulate_piece(const gaussian_field& field, const std::vector<numbered_vertex>& piece, const cell_id& cell,
                       double h, int depth, triangle_list& triangles,
                       std::vector<surface_sample>& steiner, std::size_t& evaluations);

/// `piece` cut in two at a point of the surface between two of its vertices (as split_at_pinch), each half
/// triangulated by triangulate_piece, and the union checked for self-intersection.
bool split_piece(const gaussian_field& field, const std::vector<numbered_vertex>& piece, const cell_id& cell, double h,
                 int depth, triangle_list& triangles, std::vector<surface_sample>& steiner,
                 std::size_t& evaluations) {
  if (piece.size() < 4) return false;
  const std::size_t kept_triangles = triangles.size(), kept_steiner = steiner.size();
  for (const auto& [i, j] : closest_vertex_pairs(piece, max_pinches_per_cut, true)) {
    surface_sample point;
    const vec3 middle = into_cross_section(0.5 * (piece[i].vertex.position + piece[j].vertex.position), cell, h);
    if (!steiner_point(field, piece, cell, h, middle, point, evaluations)) continue;
    const numbered_vertex pinch{steiner_vertex + static_cast<std::uint32_t>(steiner.size()),
                                {point.position, normalized(-point.gradient), 0}};
    steiner.push_back(point);
    if (triangulate_piece(field, loop_half(piece, i, j, pinch), cell, h, depth, triangles, steiner, evaluations) &&
        triangulate_piece(field, loop_half(piece, j, i, pinch), cell, h, depth, triangles, steiner, evaluations)) {
      const triangle_list mine(triangles.begin() + kept_triangles, triangles.end());
      if (!pieces_meet(piece, steiner, mine)) return true;
    }
    triangles.resize(kept_triangles);
    steiner.resize(kept_steiner);
  }
  return false;
}

bool triangulate_piece(const gaussian_field& field, const std::vector<numbered_vertex>& piece, const cell_id& cell,
                       double h, int depth, triangle_list& triangles,
                       std::vector<surface_sample>& steiner, std::size_t& evaluations) {
  for (const loop_strategy s : split_half_strategies) {
    loop_mesh m;
    if (!triangulate_by(field, piece, cell, h, s, m, evaluations)) continue;
    if (pieces_meet(piece, steiner, m.triangles)) continue;
    triangles.insert(triangles.end(), m.triangles.begin(), m.triangles.end());
    return true;
  }
  return depth > 0 && split_piece(field, piece, cell, h, depth - 1, triangles, steiner, evaluations);
}

/// A loop that no strategy and no tube band closes because every triangulation of it crosses itself: a long sheet
/// along the cell that touches its walls again and again (sharp kernels, nearly fused spheres), whose triangles span
/// its length and pass through each other. Algorithm 2 assumes the polygon bounds a disk its vertices can span; a
/// disk that long needs vertices inside it. The loop is cut at a pinch as in split_at_pinch, and a piece whose every
/// triangulation still crosses itself is cut again (split_piece), at most max_pinch_depth times below the first cut,
/// each cut chosen from the closest vertex pairs not on a common wall; every piece keeps the wall rule.
bool split_at_pinches(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell,
                      double h, loop_mesh& out, std::size_t& evaluations) {
  out = loop_mesh{};
  out.strategy = loop_strategy::split_at_pinches;
  if (split_piece(field, loop, cell, h, max_pinch_depth, out.triangles, out.steiner, evaluations)) return true;
  out = loop_mesh{};
  return false;
}

/// The loop's triangles by `strategy`; false when that strategy cannot triangulate it. The strategies that drop the
/// wall rule (unrestricted, in_its_plane) keep it on `kept_walls` (cell_wall bits; mesh_cell).
bool triangulate_by(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell,
                    double h, loop_strategy strategy, loop_mesh& out, std::size_t& evaluations,
                    std::uint8_t kept_walls) {
  out = loop_mesh{};
  out.strategy = strategy;
  if (strategy == loop_strategy::steiner_fan || strategy == loop_strategy::steiner_fan_relaxed) {
    return fan_around_steiner_point(field, loop, cell, h, strategy == loop_strategy::steiner_fan, out, evaluations);
  }
  if (strategy == loop_strategy::split_at_pinch) return split_at_pinch(field, loop, cell, h, out, evaluations);
  std::vector<loop_vertex> vertices = vertices_of(loop);
  if (strategy == loop_strategy::unrestricted) {
    for (loop_vertex& v : vertices) v.planes &= kept_walls;
  }
  triangle_list local;
  loop_triangulation_settings settings;
  settings.kept_walls = kept_walls;  // read by triangulate_loop_in_its_plane only, which reads neither of the next two
  settings.maximise_normal_agreement =
      strategy == loop_strategy::admissible_flat || strategy == loop_strategy::flat_relaxed;
  if (strategy == loop_strategy::admissible_relaxed || strategy == loop_strategy::flat_relaxed ||
      strategy == loop_strategy::unrestricted) {
    settings.min_normal_cosine = -2;  // rule 2 off
  }
  const bool ok = strategy == loop_strategy::in_its_plane ? triangulate_loop_in_its_plane(vertices, local, settings)
                                                          : triangulate_loop(vertices, local, settings).has_value();
  number_triangles(loop, local, out.triangles);
  return ok;
}

/// The first strategy from `from` on that triangulates the loop (loop_strategy::none when none does).
void triangulate_from(const gaussian_field& field, const std::vector<numbered_vertex>& loop, const cell_id& cell,
                      double h, loop_strategy from, std::uint8_t kept_walls, loop_mesh& out,
                      std::size_t& evaluations) {
  for (loop_strategy s = from; s < loop_strategy::none; s = next(s)) {
    if (triangulate_by(field, loop, cell, h, s, out, evaluations, kept_walls)) return;
  }
  out = loop_mesh{};
}

/// The cell's triangles as one small mesh, for the intersection test: positions, corners as indices into them (a
/// vertex shared by two loops, a root or an arc point, gets one index), the loop of each triangle and its bounding
/// box. Kept per thread, so a cell costs no allocation once the buffers have grown.
struct cell_triangles {
  std::vector<vec3> positions;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> numbers;  // (vertex key, index into positions)
  triangle_list corners;
  std::vector<std::size_t> owner;
  std::vector<box3> boxes;

  void gather(const std::vector<std::vector<numbered_vertex>>& loops, const std::vector<loop_mesh>& meshes);
};

void cell_triangles::gather(const std::vector<std::vector<numbered_vertex>>& loops,
                            const std::vector<loop_mesh>& meshes) {
  positions.clear();
  numbers.clear();
  corners.clear();
  owner.clear();
  boxes.clear();
  // Steiner points are numbered per loop; loop + 1 in the high half keeps them apart from the mesh's vertex ids.
  const auto key = [](std::size_t loop, std::uint32_t id) {
    return id >= steiner_vertex ? (static_cast<std::uint64_t>(loop + 1) << 32) | (id - steiner_vertex)
                                : std::uint64_t{id};
  };
  for (std::size_t l = 0; l < loops.size(); ++l) {
    for (const numbered_vertex& v : loops[l]) {
      numbers.emplace_back(key(l, v.id), static_cast<std::uint32_t>(positions.size()));
      positions.push_back(v.vertex.position);
    }
    for (std::size_t n = 0; n < meshes[l].steiner.size(); ++n) {
      numbers.emplace_back(key(l, steiner_vertex + static_cast<std::uint32_t>(n)),
                           static_cast<std::uint32_t>(positions.size()));
      positions.push_back(meshes[l].steiner[n].position);
    }
  }
  std::sort(numbers.begin(), numbers.end());
  for (std::size_t l = 0; l < loops.size(); ++l) {
    for (const auto& t : meshes[l].triangles) {
      std::array<std::uint32_t, 3> c{};
      for (int i = 0; i < 3; ++i) {
        c[i] = std::lower_bound(numbers.begin(), numbers.end(), std::make_pair(key(l, t[i]), 0u))->second;
      }
      boxes.push_back(bounds_of(positions, c));
      corners.push_back(c);
      owner.push_back(l);
    }
  }
}

/// Loops (indices) that have a triangle intersecting another triangle of the cell (exact test:
/// docs/method.md#the-admissibility-rule — with admissible triangulations, triangles of different cells meet only
/// along shared arcs, so this per-cell test covers the whole mesh). Triangles whose bounding boxes are apart cannot
/// meet and are not tested.
std::vector<std::size_t> intersecting_loops(const std::vector<std::vector<numbered_vertex>>& loops,
                                            const std::vector<loop_mesh>& meshes) {
  thread_local cell_triangles cell;
  cell.gather(loops, meshes);
  std::vector<std::size_t> hit;
  for (std::size_t a = 0; a < cell.corners.size(); ++a) {
    for (std::size_t b = a + 1; b < cell.corners.size(); ++b) {
      if (cell.boxes[a].meets(cell.boxes[b]) &&
          detail::mesh_triangles_intersect(cell.positions, cell.corners[a], cell.corners[b])) {
        hit.push_back(cell.owner[a]);
        hit.push_back(cell.owner[b]);
      }
    }
  }
  std::sort(hit.begin(), hit.end());
  hit.erase(std::unique(hit.begin(), hit.end()), hit.end());
  return hit;
}

/// Makes the cell's triangles intersection-free: a loop whose triangles meet others' takes its next strategy.
/// Each round first looks for one loop whose change alone removes its intersections (so that a loop that was fine
/// is not spoilt for its neighbour's sake), else moves every loop involved on.
void resolve_intersections(const gaussian_field& field, const std::vector<std::vector<numbered_vertex>>& loops,
                           const cell_id& cell, double h, std::uint8_t kept_walls, std::vector<loop_mesh>& meshes,
                           cell_mesh& out) {
  constexpr int max_rounds = 16;
  std::vector<std::size_t> hit = intersecting_loops(loops, meshes);
  for (int round = 0; round < max_rounds && !hit.empty(); ++round) {
    bool fixed = false;
    for (const std::size_t l : hit) {
      const loop_mesh kept = meshes[l];
      for (loop_strategy s = next(kept.strategy); kept.strategy < loop_strategy::none && s < loop_strategy::none;
           s = next(s)) {
        if (!triangulate_by(field, loops[l], cell, h, s, meshes[l], out.evaluations, kept_walls)) continue;
        const std::vector<std::size_t> after = intersecting_loops(loops, meshes);
        if (!std::binary_search(after.begin(), after.end(), l)) {
          fixed = true;
          break;
        }
      }
      if (fixed) break;
      meshes[l] = kept;
    }
    if (!fixed) {
      bool changed = false;
      for (const std::size_t l : hit) {
        if (meshes[l].strategy >= loop_strategy::none) continue;
        triangulate_from(field, loops[l], cell, h, next(meshes[l].strategy), kept_walls, meshes[l], out.evaluations);
        changed = true;
      }
      if (!changed) break;
    }
    hit = intersecting_loops(loops, meshes);
  }
  out.intersecting = !hit.empty();
}

/// Bridges tried by slit_band, the shortest first.
constexpr std::size_t max_slit_bridges = 16;

/// Whether no directed edge occurs twice among `triangles`: a triangulation of a loop cut open along a bridge may
/// join some vertex to both copies of a bridge end, which glued back is one edge used twice on the same side.
bool directed_edges_unique(const triangle_list& triangles) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& t : triangles) {
    for (int i = 0; i < 3; ++i) edges.emplace_back(t[i], t[(i + 1) % 3]);
  }
  std::sort(edges.begin(), edges.end());
  return std::adjacent_find(edges.begin(), edges.end()) == edges.end();
}

/// The tube between two loops triangulated as one polygon: cut open along a bridge outer[a] — inner[b] (an edge
/// joining vertices on no common wall), the annulus is the loop outer[a], …, outer[a − 1], outer[a], inner[b], …,
/// inner[b − 1], inner[b], whose triangulations (triangulate_loop) are every triangulation of the annulus that
/// holds that bridge, not only bands: where the tube's mouth is a small part of a long loop, the rest of that loop
/// is a disk of its own (chords of the one loop), which no band has. Bridges are tried from the shortest; the first
/// that triangulates with each edge used once per side and without crossing itself (`both`: outer ++ inner) is kept,
/// in `triangles`. Returns its worst q.
std::optional<double> slit_band(const std::vector<numbered_vertex>& outer, const std::vector<numbered_vertex>& inner,
                                const std::vector<numbered_vertex>& both, triangle_list& triangles) {
  const std::size_t p = outer.size(), q = inner.size();
  std::vector<std::pair<double, std::pair<std::size_t, std::size_t>>> bridges;
  for (std::size_t a = 0; a < p; ++a) {
    for (std::size_t b = 0; b < q; ++b) {
      if ((outer[a].vertex.planes & inner[b].vertex.planes) != 0) continue;  // it would lie in a wall
      bridges.push_back({squared_norm(inner[b].vertex.position - outer[a].vertex.position), {a, b}});
    }
  }
  std::sort(bridges.begin(), bridges.end());
  if (bridges.size() > max_slit_bridges) bridges.resize(max_slit_bridges);
  std::vector<numbered_vertex> polygon;
  for (const auto& [length2, bridge] : bridges) {
    const auto [a, b] = bridge;
    polygon.clear();
    for (std::size_t n = 0; n <= p; ++n) polygon.push_back(outer[(a + n) % p]);
    for (std::size_t n = 0; n <= q; ++n) polygon.push_back(inner[(b + n) % q]);
    triangle_list local, numbered;
    const std::optional<double> worst = triangulate_loop(vertices_of(polygon), local);
    if (!worst) continue;
    number_triangles(polygon, local, numbered);
    if (!directed_edges_unique(numbered) || pieces_meet(both, {}, numbered)) continue;
    triangles = std::move(numbered);
    return worst;
  }
  return std::nullopt;
}

/// The band between two loops of a cell (triangulate_annulus, else slit_band), its vertices numbered in the mesh,
/// and its worst q. A band that crosses itself is none: its triangles obey the rules one by one, but the best-shaped
/// band of a tube bent round a corner line can still cut across the bend and pass through its own far side.
bool band_between(const std::vector<numbered_vertex>& outer, const std::vector<numbered_vertex>& inner,
                  loop_mesh& out, double& worst_quality) {
  std::vector<numbered_vertex> both = outer;
  both.insert(both.end(), inner.begin(), inner.end());
  triangle_list local, triangles;
  std::optional<double> worst = triangulate_annulus(vertices_of(outer), vertices_of(inner), local);
  if (worst) number_triangles(both, local, triangles);
  if (!worst || pieces_meet(both, {}, triangles)) worst = slit_band(outer, inner, both, triangles);
  if (!worst) return false;
  out = loop_mesh{loop_strategy::tube_band, std::move(triangles), {}};
  worst_quality = *worst;
  return true;
}

/// A loop that no strategy can triangulate bounds no disk the field's normals allow: every spanning surface of its
/// vertices folds against them. That is the short end of a tube crossing the cell (a pocket or tunnel of φ < t0
/// entering through two walls and leaving through the two others), whose surface is an annulus with another loop of
/// the cell at its other end (docs/method.md#tubes-inside-a-cell). Such a loop is meshed with that partner by the
/// band between them (triangulate_annulus, under the same wall, orientation and degeneracy rules), which keeps the
/// tube open and uses each loop edge once; the partner gives up its own disk (or had none). Among the loops whose
/// band is valid and meets none of the cell's other triangles, the band of best worst shape is taken (ties: the
/// lower loop index).
void pair_tube_loops(const std::vector<std::vector<numbered_vertex>>& loops, std::vector<loop_mesh>& meshes) {
  for (std::size_t l = 0; l < loops.size(); ++l) {
    if (meshes[l].strategy != loop_strategy::none) continue;
    std::size_t best_partner = loops.size();
    double best_quality = -1;
    loop_mesh best_band;
    for (std::size_t m = 0; m < loops.size(); ++m) {
      if (m == l || meshes[m].strategy > loop_strategy::none) continue;  // both ends of a tube may have failed
      loop_mesh band;
      double quality = 0;
      if (!band_between(loops[l], loops[m], band, quality) || !(quality > best_quality)) continue;
      const loop_mesh partner = meshes[m];
      meshes[l] = band;
      meshes[m] = loop_mesh{loop_strategy::tube_partner, {}, {}};
      const bool meets_others = !intersecting_loops(loops, meshes).empty();
      meshes[l] = loop_mesh{};
      meshes[m] = partner;
      if (meets_others) continue;
      best_partner = m;
      best_quality = quality;
      best_band = std::move(band);
    }
    if (best_partner == loops.size()) continue;
    meshes[l] = std::move(best_band);
    meshes[best_partner] = loop_mesh{loop_strategy::tube_partner, {}, {}};
  }
}

/// Adds to `walls` (cell_wall bits) the walls in which some triangle of `m` has an edge joining two vertices of `loop`
/// on that wall other than a loop edge, and to `lines` (cell_mesh::line_chords) the corner lines along which such an
/// edge runs. Only the strategies that drop the wall rule make one (every other keeps the rule on each edge it adds,
/// and its Steiner points lie off the walls), so only theirs are looked at.
void add_chords(const std::vector<numbered_vertex>& loop, const loop_mesh& m, std::uint8_t& walls,
                std::uint8_t& lines) {
  if (m.strategy != loop_strategy::unrestricted && m.strategy != loop_strategy::in_its_plane) return;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> index;  // (vertex, position in the loop)
  for (std::uint32_t n = 0; n < loop.size(); ++n) index.emplace_back(loop[n].id, n);
  std::sort(index.begin(), index.end());
  const auto at = [&](std::uint32_t id) {
    return std::lower_bound(index.begin(), index.end(), std::make_pair(id, 0u))->second;
  };
  const auto n = static_cast<std::uint32_t>(loop.size());
  for (const auto& t : m.triangles) {
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t a = at(t[c]), b = at(t[(c + 1) % 3]);
      if ((a + 1) % n == b || (b + 1) % n == a) continue;  // a loop edge: an arc's, shared with the neighbour
      const std::uint8_t shared = loop[a].vertex.planes & loop[b].vertex.planes;
      walls |= shared;
      if ((shared & (wall_y_low | wall_y_high)) != 0 && (shared & (wall_z_low | wall_z_high)) != 0) {
        lines |= static_cast<std::uint8_t>(1u << (((shared & wall_y_high) != 0) + 2 * ((shared & wall_z_high) != 0)));
      }
    }
  }
}

}  // namespace

std::size_t traced_surface::find_strip(const strip_id& strip) const {
  const auto it = std::lower_bound(strips.begin(), strips.end(), strip);
  return it != strips.end() && *it == strip ? static_cast<std::size_t>(it - strips.begin()) : strips.size();
}

cell_mesh mesh_cell(const gaussian_field& field, const traced_surface& surface, const cell_id& cell,
                    std::uint8_t kept_walls) {
  cell_mesh out;
  std::vector<cell_arc> arcs;
  std::vector<std::vector<numbered_vertex>> loops;
  if (!gather_arcs(surface, cell, arcs) || !chain_loops(arcs, loops)) {
    out.closed = false;
    return out;
  }
  out.loops = loops.size();
  const double h = surface.spacing;
  std::vector<loop_mesh> meshes(loops.size());
  for (std::size_t l = 0; l < loops.size(); ++l) {
    triangulate_from(field, loops[l], cell, h, loop_strategy::admissible, kept_walls, meshes[l], out.evaluations);
  }
  resolve_intersections(field, loops, cell, h, kept_walls, meshes, out);
  if (!out.intersecting) {
    pair_tube_loops(loops, meshes);
    // Last, so that no loop that closes otherwise changes: a loop still open is cut at several pinches, kept only
    // when its pieces meet none of the cell's other triangles.
    for (std::size_t l = 0; l < loops.size(); ++l) {
      if (meshes[l].strategy != loop_strategy::none) continue;
      loop_mesh split;
      if (!split_at_pinches(field, loops[l], cell, h, split, out.evaluations)) continue;
      meshes[l] = std::move(split);
      if (!intersecting_loops(loops, meshes).empty()) meshes[l] = loop_mesh{};
    }
  }
  for (std::size_t l = 0; l < loops.size(); ++l) {
    const loop_mesh& m = meshes[l];
    if (m.strategy == loop_strategy::none) {
      out.closed = false;
      continue;
    }
    if (m.strategy != loop_strategy::admissible &&
        (m.strategy < loop_strategy::none || m.strategy == loop_strategy::split_at_pinches)) {
      ++out.fallback_loops;
    }
    add_chords(loops[l], m, out.wall_chords, out.line_chords);
    const auto first_steiner = static_cast<std::uint32_t>(out.steiner.size());
    out.steiner.insert(out.steiner.end(), m.steiner.begin(), m.steiner.end());
    for (auto t : m.triangles) {
      for (auto& v : t) {
        if (v >= steiner_vertex) v += first_steiner;
      }
      out.triangles.push_back(t);
    }
  }
  return out;
}

}  // namespace tracemesh
