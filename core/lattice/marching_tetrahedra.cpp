#include "core/lattice/marching_tetrahedra.hpp"

#include <utility>

#include "core/lattice/lattice_sampler.hpp"

namespace tracemesh {
namespace {

using corner = std::array<int, 3>;  // offsets in {0,1}³ within a cube

/// The six tetrahedra (0, e_a, e_a + e_b, (1,1,1)) for the permutations (a, b, c) of the axes.
constexpr std::array<std::array<corner, 4>, 6> tetrahedra = [] {
  std::array<std::array<corner, 4>, 6> tets{};
  constexpr std::array<std::array<int, 3>, 6> perms{{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};
  for (std::size_t t = 0; t < 6; ++t) {
    corner a{0, 0, 0}, b{0, 0, 0}, c{1, 1, 1};
    a[perms[t][0]] = 1;
    b[perms[t][0]] = 1;
    b[perms[t][1]] = 1;
    tets[t] = {corner{0, 0, 0}, a, b, c};
  }
  return tets;
}();

/// Index 0..7 of a cube corner: x + 2y + 4z.
constexpr int corner_index(const corner& o) { return o[0] + 2 * o[1] + 4 * o[2]; }

using ivec = std::array<std::int64_t, 3>;
constexpr ivec sub(const ivec& a, const ivec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
constexpr ivec crossi(const ivec& a, const ivec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
constexpr std::int64_t doti(const ivec& a, const ivec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
/// Twice the midpoint of the edge between two corners (exact in integers).
constexpr ivec midpoint2(const corner& a, const corner& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }

/// Offset from the cube's key (edge_key(lowest corner, 0)) of the lattice edge between two corners of the cube:
/// keyed by its lower end and its direction (all directions are non-negative).
constexpr std::uint64_t edge_offset_between(const corner& a, const corner& b) {
  const bool a_is_lower = a[0] <= b[0] && a[1] <= b[1] && a[2] <= b[2];
  const corner& lo = a_is_lower ? a : b;
  const corner& hi = a_is_lower ? b : a;
  const int direction = edge_direction_index(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  return lattice::edge_key_offset(lo[0], lo[1], lo[2], direction);
}

/// True when polygon (m0, m1, m2, …) with normal (m1−m0)×(m2−m0) points from the inside corners to the outside ones.
constexpr bool faces_outward(const std::array<ivec, 3>& m, const ivec& inside_sum, std::int64_t inside_count,
                             const ivec& outside_sum, std::int64_t outside_count) {
  const ivec normal = crossi(sub(m[1], m[0]), sub(m[2], m[0]));
  // direction = centroid(outside) − centroid(inside), scaled by both counts to stay in integers
  const ivec direction{outside_sum[0] * inside_count - inside_sum[0] * outside_count,
                       outside_sum[1] * inside_count - inside_sum[1] * outside_count,
                       outside_sum[2] * inside_count - inside_sum[2] * outside_count};
  return doti(normal, direction) > 0;
}

/// The polygon one tetrahedron contributes for one pattern of inside corners: 0, 3 (triangle) or 4 (quadrilateral,
/// cyclic) cut edges as key offsets from the cube's key, oriented counter-clockwise seen from outside.
struct tet_polygon {
  int count = 0;
  std::array<std::uint64_t, 4> edges{};
};

constexpr tet_polygon polygon_of(const std::array<corner, 4>& c, unsigned inside_mask) {
  std::array<int, 4> in{}, out{};
  int n_in = 0, n_out = 0;
  ivec in_sum{0, 0, 0}, out_sum{0, 0, 0};
  for (int v = 0; v < 4; ++v) {
    const bool inside = (inside_mask >> v) & 1u;
    ivec& sum = inside ? in_sum : out_sum;
    for (int a = 0; a < 3; ++a) sum[a] += 2 * c[v][a];
    if (inside) {
      in[n_in++] = v;
    } else {
      out[n_out++] = v;
    }
  }
  tet_polygon polygon;
  if (n_in == 0 || n_out == 0) return polygon;
  if (n_in == 1 || n_out == 1) {
    // One corner alone on its side: a triangle on its three edges.
    const int apex = (n_in == 1) ? in[0] : out[0];
    const std::array<int, 3> others = (n_in == 1) ? std::array<int, 3>{out[0], out[1], out[2]}
                                                  : std::array<int, 3>{in[0], in[1], in[2]};
    std::array<ivec, 3> mids{};
    polygon.count = 3;
    for (int e = 0; e < 3; ++e) {
      polygon.edges[e] = edge_offset_between(c[apex], c[others[e]]);
      mids[e] = midpoint2(c[apex], c[others[e]]);
    }
    if (!faces_outward(mids, in_sum, n_in, out_sum, n_out)) std::swap(polygon.edges[1], polygon.edges[2]);
    return polygon;
  }
  // Two and two: the cut edges form the quadrilateral in0-out0, in0-out1, in1-out1, in1-out0 (cyclic).
  const std::array<std::pair<int, int>, 4> ring{{{in[0], out[0]}, {in[0], out[1]}, {in[1], out[1]}, {in[1], out[0]}}};
  std::array<ivec, 3> mids{};
  polygon.count = 4;
  for (int e = 0; e < 4; ++e) {
    polygon.edges[e] = edge_offset_between(c[ring[e].first], c[ring[e].second]);
    if (e < 3) mids[e] = midpoint2(c[ring[e].first], c[ring[e].second]);
  }
  if (!faces_outward(mids, in_sum, n_in, out_sum, n_out)) std::swap(polygon.edges[1], polygon.edges[3]);
  return polygon;
}

/// Every tetrahedron's polygon for every pattern of its four corners, worked out at compile time.
struct polygon_table {
  std::array<std::array<tet_polygon, 16>, 6> polygons{};
  std::array<std::array<int, 4>, 6> corners{};  ///< cube corner index of each tetrahedron corner
};

constexpr polygon_table make_polygon_table() {
  polygon_table table;
  for (std::size_t t = 0; t < 6; ++t) {
    for (int v = 0; v < 4; ++v) table.corners[t][v] = corner_index(tetrahedra[t][v]);
    for (unsigned mask = 0; mask < 16; ++mask) table.polygons[t][mask] = polygon_of(tetrahedra[t], mask);
  }
  return table;
}
constexpr polygon_table table = make_polygon_table();

}  // namespace

void triangulate_block(const lattice& lat, const lattice_index& block, std::span<const double> values, double t0,
                       block_polygons& out) {
  constexpr int n = block_points;
  const lattice_index first{block.i * lattice::block_cells, block.j * lattice::block_cells,
                            block.k * lattice::block_cells};
  const auto inside_at = [&](int x, int y, int z) { return values[static_cast<std::size_t>((z * n + y) * n + x)] >= t0; };
  for (int z = 0; z < lattice::block_cells; ++z) {
    for (int y = 0; y < lattice::block_cells; ++y) {
      for (int x = 0; x < lattice::block_cells; ++x) {
        unsigned cube_mask = 0;  // bit x + 2y + 4z set where that corner is inside
        for (int v = 0; v < 8; ++v) {
          cube_mask |= static_cast<unsigned>(inside_at(x + (v & 1), y + ((v >> 1) & 1), z + (v >> 2))) << v;
        }
        if (cube_mask == 0 || cube_mask == 0xff) continue;  // the common case by far
        const std::uint64_t cube_key = lat.edge_key({first.i + x, first.j + y, first.k + z}, 0);
        for (std::size_t t = 0; t < 6; ++t) {
          unsigned tet_mask = 0;
          for (int v = 0; v < 4; ++v) tet_mask |= ((cube_mask >> table.corners[t][v]) & 1u) << v;
          const tet_polygon& polygon = table.polygons[t][tet_mask];
          if (polygon.count == 3) {
            out.triangles.push_back({cube_key + polygon.edges[0], cube_key + polygon.edges[1], cube_key + polygon.edges[2]});
          } else if (polygon.count == 4) {
            out.quads.push_back({cube_key + polygon.edges[0], cube_key + polygon.edges[1], cube_key + polygon.edges[2],
                                 cube_key + polygon.edges[3]});
          }
        }
      }
    }
  }
}

}  // namespace tracemesh
