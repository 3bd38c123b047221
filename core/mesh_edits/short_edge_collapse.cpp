#include "core/mesh_edits/short_edge_collapse.hpp"

#include <algorithm>
#include <array>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_local_folds.hpp"
#include "core/analysis/analysis_moved_triangles.hpp"
#include "core/analysis/analysis_topology.hpp"

namespace tracemesh {
namespace {

/// A closed component needs 4 vertices at least.
constexpr std::uint32_t smallest_closed_component = 4;
/// Rounds of collapses, each after those whose triangles met others were refused: a collapse can push a fan through a
/// triangle of a neighbouring cell where the surface lies almost in a wall. A round that fails is undone whole, so
/// rounds must outlast the refusals, which come a few fewer each round.
constexpr int max_collapse_rounds = 8;
/// A pass over at least this many edges first undoes only the collapses that fail, with every later one that
/// touched what they touched, and tests again around what it put back (up to max_undo_steps times), instead of
/// making the whole round again (a sweep and a test of every moved triangle). The edges undone are tried again in
/// the next pass, a small one, whose rounds are made again whole: that tries other orders, which a cluster of close
/// vertices may need.
constexpr std::size_t undone_alone_from_edges = 10'000;
constexpr int max_undo_steps = 4;
/// Passes over the edges, each over the short edges at the vertices the previous one kept: a collapse joins the kept
/// end to the removed end's neighbours, and one of them may lie close to it.
constexpr int max_collapse_passes = 4;

using triangle = std::array<std::uint32_t, 3>;

struct candidate_edge {
  double length;
  std::uint32_t a, b;  // a < b
  friend bool operator<(const candidate_edge& l, const candidate_edge& r) {
    return std::tie(l.length, l.a, l.b) < std::tie(r.length, r.a, r.b);
  }
  friend bool operator==(const candidate_edge&, const candidate_edge&) = default;
};

/// A collapse made: `removed` merged into `kept`.
struct collapse {
  std::uint32_t kept, removed;
  candidate_edge cause;  ///< the short edge this collapse was made for (itself, or one beside its removed corner)
  std::array<std::uint32_t, 2> dropped;  ///< the two triangles on the edge
  std::size_t first_change, end_change;  ///< its records in collapser::changed_
};

/// The edges of the triangles `of_triangle` accepts that have an end numbered first_movable_vertex or above and that
/// `keep` accepts, shortest first, each once.
template <class Of_triangle, class Keep>
std::vector<candidate_edge> movable_edges(const surface_mesh& mesh, std::uint32_t first_movable_vertex,
                                          Of_triangle of_triangle, Keep keep) {
  std::vector<candidate_edge> edges;
  for (const triangle& t : mesh.triangles) {
    if (!of_triangle(t)) continue;
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t u = t[static_cast<std::size_t>(i)], v = t[static_cast<std::size_t>((i + 1) % 3)];
      if (u < first_movable_vertex && v < first_movable_vertex) continue;
      const candidate_edge e{distance(mesh.positions[u], mesh.positions[v]), std::min(u, v), std::max(u, v)};
      if (keep(e)) edges.push_back(e);
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

/// The movable edges shorter than max_length; with `at` (one flag per vertex), only those with a flagged end.
std::vector<candidate_edge> short_edges(const surface_mesh& mesh, std::uint32_t first_movable_vertex,
                                        double max_length, const std::vector<char>* at = nullptr) {
  return movable_edges(mesh, first_movable_vertex, [](const triangle&) { return true; },
                       [&](const candidate_edge& e) {
                         return e.length < max_length && (at == nullptr || (*at)[e.a] || (*at)[e.b]);
                       });
}

/// `flags` (one per vertex) and the flags of every vertex sharing a triangle with a flagged one.
std::vector<char> with_neighbours(const surface_mesh& mesh, const std::vector<char>& flags) {
  std::vector<char> out = flags;
  for (const triangle& t : mesh.triangles) {
    if (flags[t[0]] || flags[t[1]] || flags[t[2]]) out[t[0]] = out[t[1]] = out[t[2]] = 1;
  }
  return out;
}

/// flip_to_short_diagonals flips an edge only where the diagonal it makes is shorter than this × the edge: two
/// back-to-back slivers, not the ordinary quads of a component small enough for its edges to be short.
constexpr double max_diagonal_ratio = 0.1;

/// The pairs of vertices closer than `max_length` Å, one of them numbered first_movable_vertex or above, closest
/// first.
std::vector<candidate_edge> close_vertex_pairs(const surface_mesh& mesh, std::uint32_t first_movable_vertex,
                                               double max_length) {
  std::vector<candidate_edge> pairs;
  for (const auto& [a, b] : detail::vertex_pairs_closer_than(mesh, max_length)) {
    if (b >= first_movable_vertex) pairs.push_back({distance(mesh.positions[a], mesh.positions[b]), a, b});
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

/// What a round's test saw (collapser::causes_of_collapses_that_fail), so that the next round, made again without
/// the refused collapses, tests only what differs from it: a pair of triangles with the corners they had then, each
/// moved one of which passed then, would pass again (vertices never move).
struct tested_round {
  struct touched_triangle {
    std::uint32_t index;
    triangle corners;
    bool alive;
  };
  std::vector<touched_triangle> touched;  ///< the triangles the round changed or dropped, sorted by index
  std::vector<std::uint32_t> passed;      ///< the moved triangles that passed, sorted
};

/// The triangles around the vertices that a collapse can touch: the candidates' ends and their neighbours (the
/// corners that lose a triangle). A merged vertex's neighbours were its two ends' neighbours, so no collapse ever
/// needs another vertex.
class local_incidence {
 public:
  local_incidence(const surface_mesh& mesh, const std::vector<candidate_edge>& edges)
      : slot_(mesh.positions.size(), untracked) {
    std::vector<char> end(mesh.positions.size(), 0);
    for (const candidate_edge& e : edges) end[e.a] = end[e.b] = 1;
    for (const triangle& t : mesh.triangles) {
      if (!end[t[0]] && !end[t[1]] && !end[t[2]]) continue;
      for (const std::uint32_t v : t) {
        if (slot_[v] != untracked) continue;
        slot_[v] = static_cast<std::uint32_t>(lists_.size());
        lists_.emplace_back();
      }
    }
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
      for (const std::uint32_t v : mesh.triangles[f]) {
        if (slot_[v] != untracked) lists_[slot_[v]].push_back(f);
      }
    }
  }
  /// The triangles listed at v, some of which may have been removed since (the caller filters).
  std::vector<std::uint32_t>& of(std::uint32_t v) { return lists_[slot_[v]]; }

 private:
  static constexpr std::uint32_t untracked = ~std::uint32_t{0};
  std::vector<std::uint32_t> slot_;
  std::vector<std::vector<std::uint32_t>> lists_;
};

bool contains(const triangle& t, std::uint32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

/// The corner of t that is neither a nor b (a when t has no third corner, which a triangle of an edge (a, b) has).
std::uint32_t third_corner(const triangle& t, std::uint32_t a, std::uint32_t b) {
  for (const std::uint32_t v : t) {
    if (v != a && v != b) return v;
  }
  return a;
}

vec3 area_normal(const surface_mesh& mesh, const triangle& t) {
  const vec3& p = mesh.positions[t[0]];
  return cross(mesh.positions[t[1]] - p, mesh.positions[t[2]] - p);
}

/// The sum of the vertex normals at t's corners (zero without one normal per vertex).
vec3 corner_normals(const surface_mesh& mesh, const triangle& t) {
  if (mesh.normals.size() != mesh.positions.size()) return {};
  return mesh.normals[t[0]] + mesh.normals[t[1]] + mesh.normals[t[2]];
}

/// Whether t faces against the vertex normals at all three corners (detail::is_folded; never without one normal per
/// vertex): the fold the certificate refuses.
bool folded(const surface_mesh& mesh, const triangle& t) {
  return mesh.normals.size() == mesh.positions.size() && detail::is_folded(mesh, t);
}

/// Whether moving `removed` onto `kept` turns none of `around` (triangles at `removed`) over or flat, and folds none
/// against the vertex normals; those that also hold `kept` (the edge's two, which go) are skipped. A triangle that
/// faces against the surface's normals at its corners may turn over when it then faces along them: the move puts
/// it right (a raw triangle left frozen by the quality pass may face so). A triangle that leans far from the normals
/// may turn by less than a right angle and still end up facing against all three: no collapse makes such a fold.
bool moves_without_turning(const surface_mesh& mesh, const std::vector<std::uint32_t>& around, std::uint32_t removed,
                           std::uint32_t kept) {
  for (const std::uint32_t f : around) {
    const triangle& before = mesh.triangles[f];
    if (contains(before, kept)) continue;
    triangle moved = before;
    std::replace(moved.begin(), moved.end(), removed, kept);
    if (folded(mesh, moved) && !folded(mesh, before)) return false;
    const vec3 old_face = area_normal(mesh, before), new_face = area_normal(mesh, moved);
    if (dot(old_face, new_face) > 0) continue;
    const bool put_right = dot(old_face, corner_normals(mesh, before)) < 0 &&
                           dot(new_face, corner_normals(mesh, moved)) > 0;
    if (!put_right) return false;
  }
  return true;
}

/// The neighbours of v, from `around`, its triangles: sorted, each once.
std::vector<std::uint32_t> neighbours_of(const surface_mesh& mesh, const std::vector<std::uint32_t>& around,
                                         std::uint32_t v) {
  std::vector<std::uint32_t> out;
  for (const std::uint32_t f : around) {
    for (const std::uint32_t w : mesh.triangles[f]) {
      if (w != v) out.push_back(w);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// The neighbours a and b share, from their triangles around_a and around_b: sorted.
std::vector<std::uint32_t> common_neighbours(const surface_mesh& mesh, const std::vector<std::uint32_t>& around_a,
                                             const std::vector<std::uint32_t>& around_b, std::uint32_t a,
                                             std::uint32_t b) {
  const std::vector<std::uint32_t> na = neighbours_of(mesh, around_a, a), nb = neighbours_of(mesh, around_b, b);
  std::vector<std::uint32_t> common;
  std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
  return common;
}

class collapser {
 public:
  /// `labels`: the components of `mesh` (the same for every round: a round that fails is undone whole).
  collapser(surface_mesh& mesh, const std::vector<candidate_edge>& edges, std::uint32_t first_movable_vertex,
            std::uint32_t min_component_vertices, detail::component_labels& labels)
      : mesh_(mesh),
        first_movable_(first_movable_vertex),
        min_component_vertices_(std::max(min_component_vertices, smallest_closed_component)),
        incidence_(mesh, edges),
        labels_(labels),
        component_vertices_(labels_.count, 0),
        alive_(mesh.triangles.size(), 1),
        removed_(mesh.positions.size(), 0),
        retried_(mesh.positions.size(), 0) {
    for (const std::uint32_t c : labels_.of_vertex) {
      if (c < labels_.count) ++component_vertices_[c];
    }
  }

  /// Collapses edge (a, b) onto a when every condition of collapse_short_edges() holds; `corner_merged`: whether a
  /// corner of three triangles beside the edge may be merged into it first; `cause`: the candidate edge tried.
  bool try_collapse(std::uint32_t a, std::uint32_t b, bool corner_merged, const candidate_edge& cause) {
    if (removed_[a] || removed_[b]) return false;
    const std::uint32_t component = labels_.of_vertex[a];
    if (component >= labels_.count || component_vertices_[component] <= min_component_vertices_) return false;
    const std::vector<std::uint32_t> around_a = live(a), around_b = live(b);
    std::vector<std::uint32_t> on_edge;
    for (const std::uint32_t f : around_a) {
      if (contains(mesh_.triangles[f], b)) on_edge.push_back(f);
    }
    if (on_edge.size() != 2) return false;
    const std::uint32_t c = third_corner(mesh_.triangles[on_edge[0]], a, b);
    const std::uint32_t d = third_corner(mesh_.triangles[on_edge[1]], a, b);
    if (c == d) return false;
    if (live_count(c) <= 3 || live_count(d) <= 3) {
      // A corner of three triangles would be left with two. Such a corner is first merged into the nearer end of
      // the edge, or else the farther (its three triangles become one), when it may move; then the edge is tried
      // again, once. A refused try changes nothing.
      const std::uint32_t corner = live_count(c) <= 3 ? c : d;
      if (!corner_merged || corner < first_movable_ || live_count(corner) != 3) return false;
      const bool a_nearer = distance(mesh_.positions[a], mesh_.positions[corner]) <=
                            distance(mesh_.positions[b], mesh_.positions[corner]);
      const std::uint32_t near_end = a_nearer ? a : b, far_end = a_nearer ? b : a;
      if (!try_collapse(near_end, corner, false, cause) && !try_collapse(far_end, corner, false, cause)) return false;
      return try_collapse(a, b, false, cause);
    }
    const std::vector<std::uint32_t> corners{std::min(c, d), std::max(c, d)};
    if (common_neighbours(mesh_, around_a, around_b, a, b) != corners) return false;
    if (!moves_without_turning(mesh_, around_b, b, a)) return false;
    alive_[on_edge[0]] = alive_[on_edge[1]] = 0;
    const std::size_t first_change = changed_.size();
    for (const std::uint32_t f : around_b) {
      if (!alive_[f]) continue;
      changed_.push_back({f, mesh_.triangles[f]});
      std::replace(mesh_.triangles[f].begin(), mesh_.triangles[f].end(), b, a);
      incidence_.of(a).push_back(f);
    }
    removed_[b] = 1;
    --component_vertices_[component];
    collapses_.push_back({a, b, cause, {on_edge[0], on_edge[1]}, first_change, changed_.size()});
    return true;
  }

  std::size_t collapses() const { return collapses_.size(); }

  /// The causes of the collapses some of whose triangles now meet another triangle or are degenerate, by the
  /// certificate's own tests: the triangles around every kept end against each other and against every triangle
  /// whose bounding box meets theirs (the others did not move).
  /// `last`: the test of the previous round of this pass, if any, which only the triangles that differ from it need
  /// (untested_since); replaced by this round's.
  std::vector<candidate_edge> causes_of_collapses_that_fail(std::optional<tested_round>& last) {
    const std::vector<std::uint32_t> moved = moved_triangles();
    std::vector<tested_round::touched_triangle> touched = touched_triangles();
    const std::vector<std::uint32_t> failing =
        last ? detail::failing_moved_triangles_again(mesh_, alive_, moved, untested_since(*last, touched, moved))
             : detail::failing_moved_triangles(mesh_, alive_, moved);
    last = tested_round{std::move(touched), {}};
    std::set_difference(moved.begin(), moved.end(), failing.begin(), failing.end(), std::back_inserter(last->passed));
    std::unordered_set<std::uint32_t> bad_corners;
    for (const std::uint32_t f : failing) {
      for (const std::uint32_t v : mesh_.triangles[f]) bad_corners.insert(v);
    }
    std::vector<candidate_edge> causes;
    for (const collapse& done : collapses_) {
      if (bad_corners.count(done.kept) != 0) causes.push_back(done.cause);
    }
    return causes;
  }

  /// Whether the collapses pass the certificate's tests once those that fail are undone alone (undo_collapses()), in
  /// up to max_undo_steps steps. When they do not, the caller undoes the round whole and refuses `failed_causes`:
  /// the causes of every collapse found failing on the way, those already undone included (so the round made again
  /// does not repeat them). Left empty when the failures could not be traced to a collapse.
  bool settle_by_undoing_the_failed_ones(std::vector<candidate_edge>& failed_causes) {
    std::vector<std::uint32_t> failing = detail::failing_moved_triangles(mesh_, alive_, moved_triangles());
    for (int step = 0; !failing.empty(); ++step) {
      const std::vector<char> failed = collapses_changing(failing);
      for (std::size_t i = 0; i < collapses_.size(); ++i) {
        if (failed[i]) failed_causes.push_back(collapses_[i].cause);
      }
      if (step == max_undo_steps || std::none_of(failed.begin(), failed.end(), [](char flag) { return flag != 0; })) {
        return false;
      }
      failing = failing_triangles_around(undo_collapses(failed));
    }
    return true;
  }

  /// Puts every triangle back as it was before the collapses (the vertices were not moved), after
  /// settle_by_undoing_the_failed_ones() too: the earliest record of each triangle is its state before any collapse.
  void undo() {
    for (auto it = changed_.rbegin(); it != changed_.rend(); ++it) mesh_.triangles[it->first] = it->second;
  }

  /// Drops the collapsed triangles and the removed vertices, the others keeping their order (and their component
  /// labels). Returns one flag per remaining vertex: whether it was the kept end of a collapse or an end of one
  /// undone by undo_collapses() (the next pass looks at the short edges at the flagged vertices).
  std::vector<char> compact() {
    std::vector<char> kept_end = retried_;
    for (const collapse& done : collapses_) kept_end[done.kept] = 1;
    std::vector<std::uint32_t> number(mesh_.positions.size());
    std::uint32_t next = 0;
    for (std::size_t v = 0; v < number.size(); ++v) {
      if (removed_[v]) continue;
      number[v] = next;
      mesh_.positions[next] = mesh_.positions[v];
      if (mesh_.normals.size() == number.size()) mesh_.normals[next] = mesh_.normals[v];
      if (mesh_.atom_index.size() == number.size()) mesh_.atom_index[next] = mesh_.atom_index[v];
      labels_.of_vertex[next] = labels_.of_vertex[v];
      kept_end[next] = kept_end[v];
      ++next;
    }
    if (mesh_.normals.size() == number.size()) mesh_.normals.resize(next);
    if (mesh_.atom_index.size() == number.size()) mesh_.atom_index.resize(next);
    mesh_.positions.resize(next);
    labels_.of_vertex.resize(next);
    kept_end.resize(next);
    std::size_t kept = 0;
    for (std::size_t f = 0; f < mesh_.triangles.size(); ++f) {
      if (!alive_[f]) continue;
      triangle t = mesh_.triangles[f];
      for (std::uint32_t& v : t) v = number[v];
      labels_.of_triangle[kept] = labels_.of_triangle[f];
      mesh_.triangles[kept++] = t;
    }
    mesh_.triangles.resize(kept);
    labels_.of_triangle.resize(kept);
    return kept_end;
  }

 private:
  /// The live triangles at v (pruning the removed ones from its list).
  const std::vector<std::uint32_t>& live(std::uint32_t v) {
    std::vector<std::uint32_t>& list = incidence_.of(v);
    std::erase_if(list, [&](std::uint32_t f) { return !alive_[f]; });
    return list;
  }
  std::size_t live_count(std::uint32_t v) { return live(v).size(); }

  /// The triangles the collapses moved: those now around a kept end, sorted.
  std::vector<std::uint32_t> moved_triangles() {
    std::vector<std::uint32_t> moved;
    for (const collapse& done : collapses_) {
      for (const std::uint32_t f : live(done.kept)) moved.push_back(f);
    }
    std::sort(moved.begin(), moved.end());
    moved.erase(std::unique(moved.begin(), moved.end()), moved.end());
    return moved;
  }

  /// The triangles the collapses changed or dropped, as they are now, sorted by index.
  std::vector<tested_round::touched_triangle> touched_triangles() const {
    std::vector<tested_round::touched_triangle> touched;
    for (const collapse& done : collapses_) {
      for (const std::uint32_t f : done.dropped) touched.push_back({f, mesh_.triangles[f], false});
      for (std::size_t k = done.first_change; k < done.end_change; ++k) {
        const std::uint32_t f = changed_[k].first;
        touched.push_back({f, mesh_.triangles[f], alive_[f] != 0});
      }
    }
    std::sort(touched.begin(), touched.end(), [](const auto& l, const auto& r) { return l.index < r.index; });
    touched.erase(std::unique(touched.begin(), touched.end(),
                              [](const auto& l, const auto& r) { return l.index == r.index; }),
                  touched.end());
    return touched;
  }

  /// The triangles a test after `before` must look at again: the live ones this round (`touched`) or that one
  /// touched (every other triangle is as the pass found it both times) whose corners differ from then, and the moved
  /// ones that did not pass then.
  std::vector<std::uint32_t> untested_since(const tested_round& before,
                                            const std::vector<tested_round::touched_triangle>& touched,
                                            const std::vector<std::uint32_t>& moved) const {
    std::vector<std::uint32_t> retest;
    const auto same_as_then = [&](std::uint32_t f) {
      const auto it = std::lower_bound(before.touched.begin(), before.touched.end(), f,
                                       [](const auto& t, std::uint32_t index) { return t.index < index; });
      return it != before.touched.end() && it->index == f && it->alive && it->corners == mesh_.triangles[f];
    };
    for (const auto& t : touched) {
      if (alive_[t.index] && !same_as_then(t.index)) retest.push_back(t.index);
    }
    for (const auto& t : before.touched) {
      if (alive_[t.index] && !same_as_then(t.index)) retest.push_back(t.index);
    }
    for (const std::uint32_t f : moved) {
      if (!std::binary_search(before.passed.begin(), before.passed.end(), f)) retest.push_back(f);
    }
    return retest;
  }

  /// The triangles that fail the certificate's tests after undo_collapses() put back `put_back`: those and the
  /// triangles the collapses left changed near them, tested against each other and against everything near them.
  /// Every other pair of triangles is as it was when the round's test passed it.
  std::vector<std::uint32_t> failing_triangles_around(const std::vector<std::uint32_t>& put_back) const {
    const std::vector<std::uint32_t> near = detail::triangles_near(mesh_, alive_, put_back);
    std::vector<char> changed(mesh_.triangles.size(), 0);
    for (const collapse& done : collapses_) {
      for (std::size_t k = done.first_change; k < done.end_change; ++k) changed[changed_[k].first] = 1;
    }
    std::vector<std::uint32_t> moving = put_back;
    for (const std::uint32_t f : near) {
      if (changed[f]) moving.push_back(f);
    }
    return detail::failing_moved_triangles_among(mesh_, std::move(moving), near);
  }

  /// One flag per collapse: whether it was the last to change one of `triangles` (so made it fail).
  std::vector<char> collapses_changing(const std::vector<std::uint32_t>& triangles) const {
    std::unordered_map<std::uint32_t, std::size_t> last;  // triangle → the last collapse that changed it
    for (const std::uint32_t f : triangles) last.emplace(f, collapses_.size());
    for (std::size_t i = 0; i < collapses_.size(); ++i) {
      for (std::size_t k = collapses_[i].first_change; k < collapses_[i].end_change; ++k) {
        const auto it = last.find(changed_[k].first);
        if (it != last.end()) it->second = i;
      }
    }
    std::vector<char> flags(collapses_.size(), 0);
    for (const auto& entry : last) {
      if (entry.second < collapses_.size()) flags[entry.second] = 1;
    }
    return flags;
  }

  /// Undoes, latest first, the collapses flagged in `failed` and every later collapse that touched a vertex an
  /// undone one touched: each collapse left then sees the mesh it was made on, so its checks still hold. Flags the
  /// ends of every undone one for the next pass (compact()), which tries their edges again with rounds undone
  /// whole. Returns the triangles put back (alive), which must be tested again (failing_triangles_around).
  std::vector<std::uint32_t> undo_collapses(const std::vector<char>& failed) {
    std::vector<char> touched(mesh_.positions.size(), 0), undone(collapses_.size(), 0);
    for (std::size_t i = 0; i < collapses_.size(); ++i) {
      const std::vector<std::uint32_t> vertices = vertices_touched(collapses_[i]);
      const bool after_an_undone_one = std::any_of(vertices.begin(), vertices.end(), [&](std::uint32_t v) {
        return touched[v] != 0;
      });
      if (!after_an_undone_one && !failed[i]) continue;
      undone[i] = 1;
      for (const std::uint32_t v : vertices) touched[v] = 1;
      retried_[collapses_[i].kept] = retried_[collapses_[i].removed] = 1;
    }
    std::vector<std::uint32_t> put_back;
    for (std::size_t i = collapses_.size(); i-- > 0;) {
      if (!undone[i]) continue;
      const collapse& done = collapses_[i];
      for (std::size_t k = done.end_change; k-- > done.first_change;) {
        mesh_.triangles[changed_[k].first] = changed_[k].second;
        put_back.push_back(changed_[k].first);
      }
      for (const std::uint32_t f : done.dropped) {
        alive_[f] = 1;
        put_back.push_back(f);
      }
      removed_[done.removed] = 0;
    }
    std::size_t kept = 0;
    for (std::size_t i = 0; i < collapses_.size(); ++i) {
      if (!undone[i]) collapses_[kept++] = collapses_[i];
    }
    collapses_.resize(kept);
    std::erase_if(put_back, [&](std::uint32_t f) { return !alive_[f]; });
    return put_back;
  }

  /// The vertices whose triangles `done` read or changed: its kept end and the corners of the triangles it dropped
  /// and of those it changed, as they were before it (after, they only have the kept end instead of the removed one).
  std::vector<std::uint32_t> vertices_touched(const collapse& done) const {
    std::vector<std::uint32_t> vertices{done.kept};
    for (const std::uint32_t f : done.dropped) {
      vertices.insert(vertices.end(), mesh_.triangles[f].begin(), mesh_.triangles[f].end());
    }
    for (std::size_t k = done.first_change; k < done.end_change; ++k) {
      vertices.insert(vertices.end(), changed_[k].second.begin(), changed_[k].second.end());
    }
    return vertices;
  }

  surface_mesh& mesh_;
  std::uint32_t first_movable_;
  std::uint32_t min_component_vertices_;
  local_incidence incidence_;
  detail::component_labels& labels_;
  std::vector<std::uint32_t> component_vertices_;
  std::vector<char> alive_;
  std::vector<char> removed_;
  std::vector<char> retried_;  // the ends of the collapses undone by undo_collapses()
  std::vector<collapse> collapses_;  // in order
  std::vector<std::pair<std::uint32_t, triangle>> changed_;  // (triangle, corners before the collapse that changed it)
};

/// The triangles at v among those listed (a flip leaves a triangle listed at a vertex it lost).
std::vector<std::uint32_t> triangles_at(const surface_mesh& mesh, local_incidence& incidence, std::uint32_t v) {
  std::vector<std::uint32_t> at;
  for (const std::uint32_t f : incidence.of(v)) {
    if (contains(mesh.triangles[f], v)) at.push_back(f);
  }
  return at;
}

/// A flip made: two triangles and their corners before it.
struct edge_flip {
  std::array<std::uint32_t, 2> triangles;
  std::array<triangle, 2> before;
};

/// How a flip's new triangles are checked besides folds: against both old triangles, or against the vertex normals at
/// their corners (for a pair of slivers, whose faces point anywhere).
enum class flip_check { against_old_faces, along_vertex_normals };

/// Flips the edge (v, e) of the triangles (v, e, x) and (e, v, y) into (x, y) when the mesh stays manifold (no edge
/// (x, y) yet, v and e keep three triangles or more), neither new triangle is folded against the vertex normals, and
/// neither turns against either old one (or, with flip_check::along_vertex_normals, each faces along the sum of the
/// normals at its corners).
std::optional<edge_flip> flip(surface_mesh& mesh, local_incidence& incidence, std::uint32_t v, std::uint32_t e,
                              flip_check check = flip_check::against_old_faces) {
  const std::vector<std::uint32_t> around_v = triangles_at(mesh, incidence, v);
  std::vector<std::uint32_t> on_edge;
  for (const std::uint32_t f : around_v) {
    if (contains(mesh.triangles[f], e)) on_edge.push_back(f);
  }
  if (on_edge.size() != 2 || around_v.size() <= 3 || triangles_at(mesh, incidence, e).size() <= 3) return std::nullopt;
  const auto follows = [&](std::uint32_t f, std::uint32_t first, std::uint32_t second) {
    const triangle& t = mesh.triangles[f];
    for (int i = 0; i < 3; ++i) {
      if (t[static_cast<std::size_t>(i)] == first && t[static_cast<std::size_t>((i + 1) % 3)] == second) return true;
    }
    return false;
  };
  if (!follows(on_edge[0], v, e)) std::swap(on_edge[0], on_edge[1]);
  if (!follows(on_edge[0], v, e) || !follows(on_edge[1], e, v)) return std::nullopt;
  const std::uint32_t x = third_corner(mesh.triangles[on_edge[0]], v, e);
  const std::uint32_t y = third_corner(mesh.triangles[on_edge[1]], v, e);
  const std::vector<std::uint32_t> around_x = triangles_at(mesh, incidence, x);
  if (x == y || std::any_of(around_x.begin(), around_x.end(), [&](std::uint32_t f) {
        return contains(mesh.triangles[f], y);
      })) {
    return std::nullopt;
  }
  const edge_flip made{{on_edge[0], on_edge[1]}, {mesh.triangles[on_edge[0]], mesh.triangles[on_edge[1]]}};
  const triangle first{y, e, x}, second{x, v, y};
  for (const triangle& now : {first, second}) {
    if (folded(mesh, now)) return std::nullopt;
    if (check == flip_check::along_vertex_normals) {
      if (!(dot(area_normal(mesh, now), corner_normals(mesh, now)) > 0)) return std::nullopt;
      continue;
    }
    for (const triangle& old : made.before) {
      if (!(dot(area_normal(mesh, now), area_normal(mesh, old)) > 0)) return std::nullopt;
    }
  }
  mesh.triangles[on_edge[0]] = first;
  mesh.triangles[on_edge[1]] = second;
  incidence.of(y).push_back(on_edge[0]);
  incidence.of(x).push_back(on_edge[1]);
  return made;
}

/// Puts a flip's two triangles back as they were.
void undo(surface_mesh& mesh, const edge_flip& f) {
  mesh.triangles[f.triangles[0]] = f.before[0];
  mesh.triangles[f.triangles[1]] = f.before[1];
}

/// Undoes the flips some of whose triangles the certificate's tests fail, until the rest pass (an undone flip's
/// triangles are tested again with them).
void undo_failing_flips(surface_mesh& mesh, std::vector<edge_flip>& flips) {
  for (bool failed = true; failed && !flips.empty();) {
    std::vector<std::uint32_t> moved;
    for (const edge_flip& f : flips) moved.insert(moved.end(), f.triangles.begin(), f.triangles.end());
    const std::vector<std::uint32_t> failing = detail::failing_moved_triangles(mesh, {}, std::move(moved));
    failed = !failing.empty();
    std::erase_if(flips, [&](const edge_flip& f) {
      const bool fails = std::any_of(f.triangles.begin(), f.triangles.end(), [&](std::uint32_t t) {
        return std::binary_search(failing.begin(), failing.end(), t);
      });
      if (fails) undo(mesh, f);
      return fails;
    });
  }
}

/// Whether collapsing `edge` (its end b onto its end a) passes the local checks of collapser::try_collapse: two
/// triangles on the edge, no third common neighbour of its ends, no triangle of b turned over.
bool collapsible(const surface_mesh& mesh, local_incidence& incidence, const candidate_edge& edge) {
  const std::vector<std::uint32_t> around_a = triangles_at(mesh, incidence, edge.a);
  const std::vector<std::uint32_t> around_b = triangles_at(mesh, incidence, edge.b);
  if (!moves_without_turning(mesh, around_b, edge.b, edge.a)) return false;
  std::vector<std::uint32_t> corners;
  for (const std::uint32_t f : around_b) {
    if (contains(mesh.triangles[f], edge.a)) corners.push_back(third_corner(mesh.triangles[f], edge.a, edge.b));
  }
  std::sort(corners.begin(), corners.end());
  return corners.size() == 2 && common_neighbours(mesh, around_a, around_b, edge.a, edge.b) == corners;
}

/// For each of `edges` whose ends a and b have a common neighbour e besides the third corners of the edge's two
/// triangles (the link condition fails: collapsing it would pinch the surface), flips (b, e), or else (a, e), when
/// that edge is not short itself, no earlier flip touched the vertices involved, and the collapse then passes its
/// local checks (collapsible). Flips some of whose triangles the certificate's tests fail are undone.
std::size_t flip_edges_blocking_links(surface_mesh& mesh, const std::vector<candidate_edge>& edges,
                                      double max_length) {
  local_incidence incidence(mesh, edges);
  std::vector<char> touched(mesh.positions.size(), 0);
  std::vector<edge_flip> flips;
  for (const candidate_edge& edge : edges) {
    if (touched[edge.a] || touched[edge.b]) continue;
    const std::vector<std::uint32_t> common =
        common_neighbours(mesh, triangles_at(mesh, incidence, edge.a), triangles_at(mesh, incidence, edge.b), edge.a,
                          edge.b);
    if (common.size() != 3) continue;  // two are the edge's corners; more than one other is left alone
    for (const std::uint32_t e : common) {
      if (touched[e]) continue;
      std::optional<edge_flip> made;
      for (const std::uint32_t v : {edge.b, edge.a}) {
        if (distance(mesh.positions[v], mesh.positions[e]) < max_length) continue;
        made = flip(mesh, incidence, v, e);
        if (!made) continue;
        if (collapsible(mesh, incidence, edge)) break;
        undo(mesh, *made);
        made.reset();
      }
      if (!made) continue;
      for (const std::uint32_t f : made->triangles) {
        for (const std::uint32_t w : mesh.triangles[f]) touched[w] = 1;
      }
      touched[edge.a] = touched[edge.b] = 1;
      flips.push_back(*made);
      break;
    }
  }
  undo_failing_flips(mesh, flips);
  return flips.size();
}

/// One pass: collapses `edges` in order where allowed, in rounds that each refuse the collapses the certificate's
/// tests fail, and compacts the mesh (and `labels`) when a round passes. Returns the collapses made and sets
/// `kept_ends` (one flag per remaining vertex) to the vertices that kept a collapse.
std::size_t collapse_pass(surface_mesh& mesh, std::vector<candidate_edge> edges, std::uint32_t first_movable_vertex,
                          std::uint32_t min_component_vertices, detail::component_labels& labels,
                          std::vector<char>& kept_ends) {
  std::optional<tested_round> last_test;
  for (int round = 0; round < max_collapse_rounds && !edges.empty(); ++round) {
    collapser w(mesh, edges, first_movable_vertex, min_component_vertices, labels);
    for (const candidate_edge& e : edges) {
      // The lower-numbered end is kept (a line root of the raw trace mesh is never removed). Where that is refused,
      // a triangle turning over, say, the other end may be kept when both may move.
      if (!w.try_collapse(e.a, e.b, true, e) && e.a >= first_movable_vertex) w.try_collapse(e.b, e.a, true, e);
    }
    std::vector<candidate_edge> refused;
    const bool settled = edges.size() >= undone_alone_from_edges ? w.settle_by_undoing_the_failed_ones(refused)
                                                                 : false;
    if (!settled && refused.empty()) refused = w.causes_of_collapses_that_fail(last_test);
    if (settled || refused.empty()) {
      const std::size_t collapsed = w.collapses();
      kept_ends = w.compact();
      return collapsed;
    }
    w.undo();
    std::sort(refused.begin(), refused.end());
    std::erase_if(edges, [&](const candidate_edge& e) {
      return std::binary_search(refused.begin(), refused.end(), e);
    });
  }
  return 0;
}

}  // namespace

std::size_t collapse_short_edges(surface_mesh& mesh, std::uint32_t first_movable_vertex, double max_length,
                                 std::uint32_t min_component_vertices, blocked_links links) {
  std::vector<candidate_edge> edges = short_edges(mesh, first_movable_vertex, max_length);
  if (edges.empty()) return 0;
  // The input's triangles are well formed (a raw trace mesh by construction, the quality pass's output by its
  // checks): components need no geometric classification of every triangle.
  detail::component_labels labels = detail::label_components(
      mesh, std::vector<detail::triangle_defect>(mesh.triangles.size(), detail::triangle_defect::none));
  std::size_t total = 0;
  for (int pass = 0; pass < max_collapse_passes && !edges.empty(); ++pass) {
    if (links == blocked_links::flipped) flip_edges_blocking_links(mesh, edges, max_length);
    std::vector<char> kept_ends;
    total += collapse_pass(mesh, std::move(edges), first_movable_vertex, min_component_vertices, labels, kept_ends);
    // Nothing flagged: every round failed (kept_ends left empty), or nothing was collapsed nor undone.
    if (std::none_of(kept_ends.begin(), kept_ends.end(), [](char flag) { return flag != 0; })) break;
    // Where links may be flipped, the next pass also looks again beside a kept end: that collapse may have given a
    // neighbouring short edge a third common neighbour, which the next pass's flips free.
    if (links == blocked_links::flipped) kept_ends = with_neighbours(mesh, kept_ends);
    edges = short_edges(mesh, first_movable_vertex, max_length, &kept_ends);
  }
  return total;
}

std::size_t flip_to_short_diagonals(surface_mesh& mesh, std::uint32_t first_movable_vertex, double max_length) {
  const std::vector<candidate_edge> pairs = close_vertex_pairs(mesh, first_movable_vertex, max_length);
  local_incidence incidence(mesh, pairs);
  std::vector<char> touched(mesh.positions.size(), 0);
  std::vector<edge_flip> flips;
  for (const candidate_edge& pair : pairs) {
    if (touched[pair.a] || touched[pair.b]) continue;
    // An edge is collapsed as it is. (No flip has touched a's triangles: its list is exact.)
    const std::vector<std::uint32_t>& at_a = incidence.of(pair.a);
    if (std::any_of(at_a.begin(), at_a.end(), [&](std::uint32_t f) { return contains(mesh.triangles[f], pair.b); })) {
      continue;
    }
    const std::vector<std::uint32_t> common = common_neighbours(
        mesh, triangles_at(mesh, incidence, pair.a), triangles_at(mesh, incidence, pair.b), pair.a, pair.b);
    if (common.size() != 2 || touched[common[0]] || touched[common[1]]) continue;
    // (c, d) must be the edge between them: its two triangles' third corners are a and b.
    const std::uint32_t c = common[0], d = common[1];
    std::vector<std::uint32_t> corners;
    for (const std::uint32_t f : triangles_at(mesh, incidence, c)) {
      if (contains(mesh.triangles[f], d)) corners.push_back(third_corner(mesh.triangles[f], c, d));
    }
    std::sort(corners.begin(), corners.end());
    if (corners != std::vector<std::uint32_t>{pair.a, pair.b}) continue;
    if (!(pair.length < max_diagonal_ratio * distance(mesh.positions[c], mesh.positions[d]))) continue;
    const std::optional<edge_flip> made = flip(mesh, incidence, c, d, flip_check::along_vertex_normals);
    if (!made) continue;
    for (const std::uint32_t v : {pair.a, pair.b, c, d}) touched[v] = 1;
    flips.push_back(*made);
  }
  undo_failing_flips(mesh, flips);
  return flips.size();
}

std::size_t collapse_folded_triangles(surface_mesh& mesh, std::uint32_t first_movable_vertex) {
  if (mesh.normals.size() != mesh.positions.size()) return 0;
  detail::component_labels labels = detail::label_components(
      mesh, std::vector<detail::triangle_defect>(mesh.triangles.size(), detail::triangle_defect::none));
  std::size_t total = 0;
  for (int pass = 0; pass < max_collapse_passes; ++pass) {
    std::vector<candidate_edge> edges = movable_edges(
        mesh, first_movable_vertex, [&](const triangle& t) { return detail::is_folded(mesh, t); },
        [](const candidate_edge&) { return true; });
    if (edges.empty()) break;
    std::vector<char> kept_ends;
    const std::size_t collapsed =
        collapse_pass(mesh, std::move(edges), first_movable_vertex, default_min_component_vertices, labels, kept_ends);
    if (collapsed == 0) break;
    total += collapsed;
  }
  return total;
}

}  // namespace tracemesh
