#include "core/marching_tetrahedra.hpp"

#include <utility>

#include "core/lattice_sampler.hpp"

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

struct tet_corner {
  lattice_index p;      // global lattice index
  std::array<std::int64_t, 3> twice;  // 2·(local offset), for exact orientation with edge midpoints
  bool inside;
};

/// Key of the lattice edge between two corners of one cube (directions are all non-negative).
std::uint64_t edge_between(const lattice& lat, const tet_corner& a, const tet_corner& b) {
  const tet_corner& lo = (a.twice[0] <= b.twice[0] && a.twice[1] <= b.twice[1] && a.twice[2] <= b.twice[2]) ? a : b;
  const tet_corner& hi = (&lo == &a) ? b : a;
  const int direction = edge_direction_index(static_cast<int>(hi.p.i - lo.p.i), static_cast<int>(hi.p.j - lo.p.j),
                                             static_cast<int>(hi.p.k - lo.p.k));
  return lat.edge_key(lo.p, direction);
}

using ivec = std::array<std::int64_t, 3>;
ivec midpoint2(const tet_corner& a, const tet_corner& b) {  // 2 × midpoint in half-cell units → a.twice + b.twice
  return {a.twice[0] + b.twice[0], a.twice[1] + b.twice[1], a.twice[2] + b.twice[2]};
}
ivec sub(const ivec& a, const ivec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
ivec crossi(const ivec& a, const ivec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
std::int64_t doti(const ivec& a, const ivec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/// True when polygon (m0, m1, m2, …) with normal (m1−m0)×(m2−m0) points from the inside corners to the outside ones.
bool faces_outward(const std::array<ivec, 3>& m, const ivec& inside_sum, std::int64_t inside_count,
                   const ivec& outside_sum, std::int64_t outside_count) {
  const ivec normal = crossi(sub(m[1], m[0]), sub(m[2], m[0]));
  // direction = centroid(outside) − centroid(inside), scaled by both counts to stay in integers
  const ivec direction{outside_sum[0] * inside_count - inside_sum[0] * outside_count,
                       outside_sum[1] * inside_count - inside_sum[1] * outside_count,
                       outside_sum[2] * inside_count - inside_sum[2] * outside_count};
  return doti(normal, direction) > 0;
}

void emit_tetrahedron(const lattice& lat, const std::array<tet_corner, 4>& c, block_polygons& out) {
  std::array<int, 4> in{}, outside{};
  int n_in = 0, n_out = 0;
  ivec in_sum{0, 0, 0}, out_sum{0, 0, 0};
  for (int v = 0; v < 4; ++v) {
    ivec& sum = c[v].inside ? in_sum : out_sum;
    for (int a = 0; a < 3; ++a) sum[a] += c[v].twice[a];
    if (c[v].inside) in[n_in++] = v;
    else outside[n_out++] = v;
  }
  if (n_in == 0 || n_out == 0) return;
  if (n_in == 1 || n_out == 1) {
    // One corner alone on its side: a triangle on its three edges.
    const int apex = (n_in == 1) ? in[0] : outside[0];
    const std::array<int, 3> others = (n_in == 1) ? std::array<int, 3>{outside[0], outside[1], outside[2]}
                                                  : std::array<int, 3>{in[0], in[1], in[2]};
    std::array<std::uint64_t, 3> keys{};
    std::array<ivec, 3> mids{};
    for (int e = 0; e < 3; ++e) {
      keys[e] = edge_between(lat, c[apex], c[others[e]]);
      mids[e] = midpoint2(c[apex], c[others[e]]);
    }
    if (!faces_outward(mids, in_sum, n_in, out_sum, n_out)) {
      std::swap(keys[1], keys[2]);
    }
    out.triangles.push_back(keys);
    return;
  }
  // Two and two: the cut edges form the quadrilateral in0-out0, in0-out1, in1-out1, in1-out0 (cyclic).
  const std::array<std::pair<int, int>, 4> ring{{{in[0], outside[0]}, {in[0], outside[1]}, {in[1], outside[1]},
                                                 {in[1], outside[0]}}};
  std::array<std::uint64_t, 4> keys{};
  std::array<ivec, 3> mids{};
  for (int e = 0; e < 4; ++e) {
    keys[e] = edge_between(lat, c[ring[e].first], c[ring[e].second]);
    if (e < 3) mids[e] = midpoint2(c[ring[e].first], c[ring[e].second]);
  }
  if (!faces_outward(mids, in_sum, n_in, out_sum, n_out)) {
    std::swap(keys[1], keys[3]);
  }
  out.quads.push_back(keys);
}

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
        // Skip cubes whose eight corners agree: the common case by far.
        const bool first_inside = inside_at(x, y, z);
        bool mixed = false;
        for (int v = 1; v < 8 && !mixed; ++v) mixed = inside_at(x + (v & 1), y + ((v >> 1) & 1), z + (v >> 2)) != first_inside;
        if (!mixed) continue;
        for (const auto& tet : tetrahedra) {
          std::array<tet_corner, 4> corners{};
          for (int v = 0; v < 4; ++v) {
            const corner& o = tet[v];
            corners[v].p = {first.i + x + o[0], first.j + y + o[1], first.k + z + o[2]};
            corners[v].twice = {2 * o[0], 2 * o[1], 2 * o[2]};
            corners[v].inside = inside_at(x + o[0], y + o[1], z + o[2]);
          }
          emit_tetrahedron(lat, corners, out);
        }
      }
    }
  }
}

}  // namespace tracemesh
