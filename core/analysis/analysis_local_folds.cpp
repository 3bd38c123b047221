#include "core/analysis/analysis_local_folds.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "core/analysis/analysis_parallel.hpp"

namespace tracemesh::detail {
namespace {

/// Bits per axis of a grid cell's coordinates, packed three to a 64-bit key.
constexpr int cell_bits = 21;
constexpr std::int64_t max_cell_coordinate = (std::int64_t{1} << cell_bits) - 1;

/// The distinct neighbours of `vertex` over its fan (appended to `out`, which is cleared first).
void fan_neighbours(const surface_mesh& mesh, const vertex_fans& fans, std::uint32_t vertex,
                    std::vector<std::uint32_t>& out) {
  out.clear();
  for (const std::uint32_t t : fans.around(vertex)) {
    for (const std::uint32_t w : mesh.triangles[t]) {
      if (w != vertex) out.push_back(w);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

/// Per vertex, near_duplicate_fraction × the median length of its edges; 0 for a vertex of no well-formed triangle
/// or with an unusable coordinate (such vertices take no part).
std::vector<double> near_duplicate_radii(const surface_mesh& mesh, const vertex_fans& fans) {
  std::vector<double> radii(mesh.positions.size(), 0.0);
  for_each_chunk(mesh.positions.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> neighbours;
    std::vector<double> lengths;
    for (std::size_t v = begin; v < end; ++v) {
      if (!usable_coordinate(mesh.positions[v])) continue;
      fan_neighbours(mesh, fans, static_cast<std::uint32_t>(v), neighbours);
      lengths.clear();
      for (const std::uint32_t w : neighbours) {
        if (usable_coordinate(mesh.positions[w])) lengths.push_back(distance(mesh.positions[v], mesh.positions[w]));
      }
      if (lengths.empty()) continue;
      const auto middle = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
      std::nth_element(lengths.begin(), middle, lengths.end());
      radii[v] = near_duplicate_fraction * *middle;
    }
  });
  return radii;
}

/// A sparse grid of cubic cells over the vertices that take part, as (cell key, vertex) entries sorted by key.
class vertex_grid {
 public:
  vertex_grid(const surface_mesh& mesh, const std::vector<double>& radii) {
    vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            std::numeric_limits<double>::infinity()};
    vec3 hi = -lo;
    double largest_radius = 0;
    for (std::size_t v = 0; v < radii.size(); ++v) {
      if (!(radii[v] > 0)) continue;
      largest_radius = std::max(largest_radius, radii[v]);
      for (int axis = 0; axis < 3; ++axis) {
        lo[axis] = std::min(lo[axis], mesh.positions[v][axis]);
        hi[axis] = std::max(hi[axis], mesh.positions[v][axis]);
      }
    }
    if (!(largest_radius > 0)) return;
    origin_ = lo;
    // Cells at least as large as the largest radius, so a pair within it lies in the same or adjacent cells;
    // larger when the coordinates would not fit the key.
    const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    cell_size_ = std::max(largest_radius, extent / static_cast<double>(max_cell_coordinate - 1));
    for (std::size_t v = 0; v < radii.size(); ++v) {
      if (radii[v] > 0) entries_.emplace_back(key(cell_of(mesh.positions[v])), static_cast<std::uint32_t>(v));
    }
    std::sort(entries_.begin(), entries_.end());
  }

  /// Calls visit(w) for every vertex w in the 27 cells around p.
  template <class Visit>
  void for_each_near(const vec3& p, Visit&& visit) const {
    if (entries_.empty()) return;
    const std::array<std::int64_t, 3> c = cell_of(p);
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const std::array<std::int64_t, 3> n{c[0] + dx, c[1] + dy, c[2] + dz};
          if (!inside(n)) continue;
          const std::uint64_t k = key(n);
          auto it = std::lower_bound(entries_.begin(), entries_.end(), std::pair<std::uint64_t, std::uint32_t>{k, 0});
          for (; it != entries_.end() && it->first == k; ++it) visit(it->second);
        }
      }
    }
  }

 private:
  std::array<std::int64_t, 3> cell_of(const vec3& p) const {
    std::array<std::int64_t, 3> c{};
    for (int axis = 0; axis < 3; ++axis) {
      c[axis] = std::clamp(static_cast<std::int64_t>(std::floor((p[axis] - origin_[axis]) / cell_size_)),
                           std::int64_t{0}, max_cell_coordinate);
    }
    return c;
  }
  static bool inside(const std::array<std::int64_t, 3>& c) {
    return std::all_of(c.begin(), c.end(), [](std::int64_t x) { return x >= 0 && x <= max_cell_coordinate; });
  }
  static std::uint64_t key(const std::array<std::int64_t, 3>& c) {
    return (static_cast<std::uint64_t>(c[0]) << (2 * cell_bits)) | (static_cast<std::uint64_t>(c[1]) << cell_bits) |
           static_cast<std::uint64_t>(c[2]);
  }

  vec3 origin_{};
  double cell_size_ = 1;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> entries_;
};

/// Whether `a` and `b` are the two ends of an edge of a's fan.
bool share_an_edge(const surface_mesh& mesh, const vertex_fans& fans, std::uint32_t a, std::uint32_t b) {
  const auto around = fans.around(a);
  return std::any_of(around.begin(), around.end(), [&](std::uint32_t t) {
    const std::array<std::uint32_t, 3>& tri = mesh.triangles[t];
    return tri[0] == b || tri[1] == b || tri[2] == b;
  });
}

}  // namespace

bool is_folded(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& t) {
  const vec3& a = mesh.positions[t[0]];
  const vec3 face = cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a);
  return dot(face, mesh.normals[t[0]]) < 0 && dot(face, mesh.normals[t[1]]) < 0 && dot(face, mesh.normals[t[2]]) < 0;
}

std::size_t count_folded_triangles(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  if (mesh.normals.empty() || mesh.normals.size() != mesh.positions.size()) return 0;
  return deterministic_reduce(
      mesh.triangles.size(), std::size_t{0},
      [&](std::size_t begin, std::size_t end) {
        std::size_t folded = 0;
        for (std::size_t t = begin; t < end; ++t) {
          if (has_usable_geometry(defects[t]) && is_folded(mesh, mesh.triangles[t])) ++folded;
        }
        return folded;
      },
      [](std::size_t total, std::size_t part) { return total + part; });
}

std::size_t count_near_duplicate_vertex_pairs(const surface_mesh& mesh, const vertex_fans& fans) {
  const std::vector<double> radii = near_duplicate_radii(mesh, fans);
  const vertex_grid grid(mesh, radii);
  return deterministic_reduce(
      mesh.positions.size(), std::size_t{0},
      [&](std::size_t begin, std::size_t end) {
        std::size_t pairs = 0;
        for (std::size_t v = begin; v < end; ++v) {
          if (!(radii[v] > 0)) continue;
          const auto a = static_cast<std::uint32_t>(v);
          grid.for_each_near(mesh.positions[a], [&](std::uint32_t b) {
            if (b <= a) return;  // each pair once, from its smaller vertex
            const double within = std::min(radii[a], radii[b]);
            if (distance(mesh.positions[a], mesh.positions[b]) < within && !share_an_edge(mesh, fans, a, b)) ++pairs;
          });
        }
        return pairs;
      },
      [](std::size_t total, std::size_t part) { return total + part; });
}

}  // namespace tracemesh::detail
