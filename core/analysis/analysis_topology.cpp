#include "core/analysis/analysis_topology.hpp"

#include <algorithm>
#include <iterator>
#include <numeric>
#include <utility>

#include "core/analysis/analysis_parallel.hpp"

namespace tracemesh::detail {
namespace {

/// Disjoint sets over 0 … n − 1 with path halving. The smaller index becomes the root, so the partition and its
/// roots depend only on the sets, not on the order of unions.
class union_find {
 public:
  explicit union_find(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), std::uint32_t{0}); }

  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), std::uint32_t{0});
  }

  std::uint32_t find(std::uint32_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }

  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a < b) parent_[b] = a;
    if (b < a) parent_[a] = b;
  }

  std::size_t size() const { return parent_.size(); }

 private:
  std::vector<std::uint32_t> parent_;
};

/// Index of `value` in a sorted vector that holds it.
std::uint32_t position_in(const std::vector<std::uint32_t>& sorted, std::uint32_t value) {
  return static_cast<std::uint32_t>(std::lower_bound(sorted.begin(), sorted.end(), value) - sorted.begin());
}

/// A use of edge (v, other), other > v, by one triangle, in direction v→other (forward) or other→v.
struct half_edge_use {
  std::uint32_t other;
  bool forward;
  friend bool operator<(const half_edge_use& a, const half_edge_use& b) {
    return a.other < b.other || (a.other == b.other && a.forward < b.forward);
  }
};

/// Census results of one chunk of vertices.
struct census_chunk {
  std::size_t boundary_edges = 0, non_manifold_edges = 0, inconsistently_oriented_edges = 0;
  std::size_t non_manifold_vertices = 0;
  std::vector<edge_key> boundary;
  std::vector<double> lengths;
};

/// Reusable per-chunk scratch space for the per-vertex work.
struct vertex_scratch {
  std::vector<fan_corner> corners;
  std::vector<half_edge_use> uses;
  std::vector<std::uint32_t> neighbours;
  union_find fan_sets{0};
};

/// Classifies the edges (v, w > v) from the sorted uses around v; returns how many distinct edges there are.
std::uint32_t census_edges_at(const surface_mesh& mesh, std::uint32_t v, const std::vector<half_edge_use>& uses,
                              census_chunk& out) {
  std::uint32_t edges = 0;
  for (std::size_t first = 0; first < uses.size();) {
    std::size_t last = first;
    std::size_t forward = 0;
    while (last < uses.size() && uses[last].other == uses[first].other) forward += uses[last++].forward ? 1 : 0;
    const std::size_t triangles = last - first;
    const std::uint32_t w = uses[first].other;
    ++edges;
    if (triangles == 1) {
      ++out.boundary_edges;
      out.boundary.push_back({v, w});
    } else if (triangles > 2) {
      ++out.non_manifold_edges;
    } else if (forward != 1) {
      ++out.inconsistently_oriented_edges;
    }
    if (usable_coordinate(mesh.positions[v]) && usable_coordinate(mesh.positions[w])) {
      out.lengths.push_back(distance(mesh.positions[v], mesh.positions[w]));
    }
    first = last;
  }
  return edges;
}

/// Triangles around v are joined when they share an edge (v, x), i.e. a neighbour x: they form one fan when the
/// "link" graph (neighbours joined by each triangle's opposite edge next–prev) is connected.
bool is_single_fan(vertex_scratch& scratch) {
  std::vector<std::uint32_t>& neighbours = scratch.neighbours;
  neighbours.clear();
  for (const fan_corner& corner : scratch.corners) {
    neighbours.push_back(corner.next);
    neighbours.push_back(corner.prev);
  }
  std::sort(neighbours.begin(), neighbours.end());
  neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
  scratch.fan_sets.reset(neighbours.size());
  for (const fan_corner& corner : scratch.corners) {
    scratch.fan_sets.unite(position_in(neighbours, corner.next), position_in(neighbours, corner.prev));
  }
  for (std::uint32_t i = 1; i < neighbours.size(); ++i) {
    if (scratch.fan_sets.find(i) != 0) return false;  // roots are the smallest member: all must reach 0
  }
  return true;
}

/// The common case: a closed manifold fan. Each edge (v, w) is used once in each direction, so there is nothing
/// to classify; only the lengths of the edges with w > v are recorded.
std::uint32_t census_closed_fan(const surface_mesh& mesh, std::uint32_t v, const std::vector<fan_corner>& corners,
                                census_chunk& out) {
  std::uint32_t edges = 0;
  const bool v_usable = usable_coordinate(mesh.positions[v]);
  for (const fan_corner& corner : corners) {
    if (corner.next < v) continue;
    ++edges;
    if (v_usable && usable_coordinate(mesh.positions[corner.next])) {
      out.lengths.push_back(distance(mesh.positions[v], mesh.positions[corner.next]));
    }
  }
  return edges;
}

/// Any other fan: sorts the uses of each edge (v, w > v) and checks that the triangles are edge-connected.
std::uint32_t census_general_fan(const surface_mesh& mesh, std::uint32_t v, vertex_scratch& scratch,
                                 census_chunk& out) {
  scratch.uses.clear();
  for (const fan_corner& corner : scratch.corners) {
    if (corner.next > v) scratch.uses.push_back({corner.next, true});
    if (corner.prev > v) scratch.uses.push_back({corner.prev, false});
  }
  std::sort(scratch.uses.begin(), scratch.uses.end());
  const std::uint32_t edges = census_edges_at(mesh, v, scratch.uses, out);
  if (!is_single_fan(scratch)) ++out.non_manifold_vertices;
  return edges;
}

/// Census of the edges at their smaller end v, and the fan check of v. Returns the number of such edges.
std::uint32_t census_vertex(const surface_mesh& mesh, const vertex_fans& fans, std::uint32_t v, vertex_scratch& scratch,
                            census_chunk& out) {
  const std::span<const std::uint32_t> around = fans.around(v);
  if (around.empty()) return 0;
  read_fan_corners(mesh, v, around, scratch.corners);
  if (corners_form_one_cycle(scratch.corners)) return census_closed_fan(mesh, v, scratch.corners, out);
  return census_general_fan(mesh, v, scratch, out);
}

template <class T>
void append_and_release(std::vector<T>& destination, std::vector<T>& source) {
  destination.insert(destination.end(), source.begin(), source.end());
  std::vector<T>().swap(source);
}

/// Fans up to this size are walked by scanning all corners at each step (quadratic, allocation-free); larger ones
/// (rare: poles of latitude–longitude meshes, pathological inputs) look the next corner up in a sorted copy.
constexpr std::size_t small_fan = 16;

/// The corner whose prev is `next`, if exactly one has it; corners.size() otherwise.
std::size_t unique_corner_with_prev(const std::vector<fan_corner>& corners, std::uint32_t next) {
  std::size_t found = corners.size(), matches = 0;
  for (std::size_t j = 0; j < corners.size(); ++j) {
    if (corners[j].prev == next) {
      found = j;
      ++matches;
    }
  }
  return matches == 1 ? found : corners.size();
}

}  // namespace

void read_fan_corners(const surface_mesh& mesh, std::uint32_t vertex, std::span<const std::uint32_t> around,
                      std::vector<fan_corner>& corners) {
  corners.clear();
  for (const std::uint32_t t : around) {
    const std::array<std::uint32_t, 3>& triangle = mesh.triangles[t];
    const int k = triangle[0] == vertex ? 0 : (triangle[1] == vertex ? 1 : 2);
    corners.push_back({triangle[(k + 1) % 3], triangle[(k + 2) % 3]});
  }
}

// Walking "to the triangle whose prev is my next" from corner 0 must find exactly one such triangle at each step
// and first return after k steps. A walk by a function that first returns to its start after k steps has visited
// k distinct corners, i.e. all of them: the function is then one k-cycle, so nexts and prevs are all distinct and
// every neighbour x is the next of one triangle and the prev of one other.
bool corners_form_one_cycle(const std::vector<fan_corner>& corners) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_prev;  // (prev, corner), for large fans only
  if (corners.size() > small_fan) {
    for (std::uint32_t i = 0; i < corners.size(); ++i) by_prev.push_back({corners[i].prev, i});
    std::sort(by_prev.begin(), by_prev.end());
  }
  const auto following = [&](std::uint32_t next) -> std::size_t {
    if (by_prev.empty()) return unique_corner_with_prev(corners, next);
    const auto first =
        std::lower_bound(by_prev.begin(), by_prev.end(), std::pair<std::uint32_t, std::uint32_t>{next, 0});
    const bool unique = first != by_prev.end() && first->first == next &&
                        (std::next(first) == by_prev.end() || std::next(first)->first != next);
    return unique ? first->second : corners.size();
  };
  std::size_t current = 0;
  for (std::size_t step = 1; step <= corners.size(); ++step) {
    current = following(corners[current].next);
    if (current == corners.size()) return false;
    if (current == 0) return step == corners.size();
  }
  return false;
}

vertex_fans build_vertex_fans(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  const std::size_t vertex_count = mesh.positions.size();
  vertex_fans fans;
  fans.offsets.assign(vertex_count + 1, 0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!is_well_formed(defects[t])) continue;
    for (const std::uint32_t v : mesh.triangles[t]) ++fans.offsets[v + 1];
  }
  std::partial_sum(fans.offsets.begin(), fans.offsets.end(), fans.offsets.begin());
  fans.triangles.resize(fans.offsets[vertex_count]);
  // Fill with offsets[v] as the cursor of v (it ends at the start of v + 1), then shift the offsets back.
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!is_well_formed(defects[t])) continue;
    for (const std::uint32_t v : mesh.triangles[t]) fans.triangles[fans.offsets[v]++] = static_cast<std::uint32_t>(t);
  }
  for (std::size_t v = vertex_count; v > 0; --v) fans.offsets[v] = fans.offsets[v - 1];
  fans.offsets[0] = 0;
  return fans;
}

edge_census take_edge_census(const surface_mesh& mesh, const vertex_fans& fans) {
  const std::size_t vertex_count = mesh.positions.size();
  edge_census census;
  census.edges_at_smaller_end.assign(vertex_count, 0);
  std::vector<census_chunk> chunks(chunk_count(vertex_count));
  for_each_chunk(vertex_count, [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    vertex_scratch scratch;
    for (std::size_t v = begin; v < end; ++v) {
      census.edges_at_smaller_end[v] = census_vertex(mesh, fans, static_cast<std::uint32_t>(v), scratch, chunks[chunk]);
    }
  });
  for (census_chunk& chunk : chunks) {
    census.boundary_edges += chunk.boundary_edges;
    census.non_manifold_edges += chunk.non_manifold_edges;
    census.inconsistently_oriented_edges += chunk.inconsistently_oriented_edges;
    census.non_manifold_vertices += chunk.non_manifold_vertices;
    append_and_release(census.boundary, chunk.boundary);
    append_and_release(census.lengths, chunk.lengths);
  }
  return census;
}

component_labels label_components(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  const std::size_t vertex_count = mesh.positions.size();
  union_find sets(vertex_count);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!is_well_formed(defects[t])) continue;
    const std::array<std::uint32_t, 3>& triangle = mesh.triangles[t];
    sets.unite(triangle[0], triangle[1]);
    sets.unite(triangle[0], triangle[2]);
  }
  component_labels labels;
  labels.of_triangle.assign(mesh.triangles.size(), no_component);
  std::vector<std::uint32_t> label_of_root(vertex_count, no_component);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!is_well_formed(defects[t])) continue;
    std::uint32_t& label = label_of_root[sets.find(mesh.triangles[t][0])];
    if (label == no_component) label = static_cast<std::uint32_t>(labels.count++);
    labels.of_triangle[t] = label;
  }
  // A vertex of no well-formed triangle is alone in its set, and its root never received a label.
  labels.of_vertex.resize(vertex_count);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    labels.of_vertex[v] = label_of_root[sets.find(static_cast<std::uint32_t>(v))];
  }
  return labels;
}

std::vector<double> component_normal_agreement(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                               const component_labels& labels) {
  std::vector<double> agreement(labels.count, 0.0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (labels.of_triangle[t] == no_component || !has_usable_geometry(defects[t])) continue;
    const std::array<std::uint32_t, 3>& triangle = mesh.triangles[t];
    const vec3& a = mesh.positions[triangle[0]];
    const vec3 face_normal = cross(mesh.positions[triangle[1]] - a, mesh.positions[triangle[2]] - a);
    const vec3 vertex_normals = mesh.normals[triangle[0]] + mesh.normals[triangle[1]] + mesh.normals[triangle[2]];
    agreement[labels.of_triangle[t]] += dot(face_normal, vertex_normals);
  }
  return agreement;
}

std::vector<std::size_t> count_boundary_loops(const edge_census& census, const component_labels& labels) {
  std::vector<std::size_t> loops(labels.count, 0);
  std::vector<std::uint32_t> vertices;
  vertices.reserve(2 * census.boundary.size());
  for (const edge_key& edge : census.boundary) {
    vertices.push_back(edge[0]);
    vertices.push_back(edge[1]);
  }
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  union_find chains(vertices.size());
  for (const edge_key& edge : census.boundary) {
    chains.unite(position_in(vertices, edge[0]), position_in(vertices, edge[1]));
  }
  for (std::uint32_t i = 0; i < vertices.size(); ++i) {
    if (chains.find(i) == i) ++loops[labels.of_vertex[vertices[i]]];
  }
  return loops;
}

}  // namespace tracemesh::detail
