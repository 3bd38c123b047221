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

/// Appends to `lengths` (cleared first) the length of the edge from `vertex` to the corner after it in each of its
/// triangles: each edge once around a closed, oriented, manifold fan (elsewhere some twice or not at all, which
/// only shifts the median a little).
void fan_edge_lengths(const surface_mesh& mesh, const vertex_fans& fans, std::uint32_t vertex,
                      std::vector<double>& lengths) {
  lengths.clear();
  const vec3& p = mesh.positions[vertex];
  for (const std::uint32_t t : fans.around(vertex)) {
    const std::array<std::uint32_t, 3>& tri = mesh.triangles[t];
    const std::uint32_t next = tri[0] == vertex ? tri[1] : tri[1] == vertex ? tri[2] : tri[0];
    if (usable_coordinate(mesh.positions[next])) lengths.push_back(distance(p, mesh.positions[next]));
  }
}

/// Per vertex, near_duplicate_fraction × the median length of its edges; 0 for a vertex of no well-formed triangle
/// or with an unusable coordinate (such vertices take no part).
std::vector<double> near_duplicate_radii(const surface_mesh& mesh, const vertex_fans& fans) {
  std::vector<double> radii(mesh.positions.size(), 0.0);
  for_each_chunk(mesh.positions.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    std::vector<double> lengths;
    for (std::size_t v = begin; v < end; ++v) {
      if (!usable_coordinate(mesh.positions[v])) continue;
      fan_edge_lengths(mesh, fans, static_cast<std::uint32_t>(v), lengths);
      if (lengths.empty()) continue;
      const auto middle = lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2);
      std::nth_element(lengths.begin(), middle, lengths.end());
      radii[v] = near_duplicate_fraction * *middle;
    }
  });
  return radii;
}

/// Cell edge in median radii (3 median edges): a surface crosses such a cell with about ten vertices, so that a
/// cell's neighbours are looked up once for all of them. Cells of the largest radius held one vertex or none, and
/// their lookups made the count cost 40% of the analysis on 3j6r_asu's raw mesh at 2 v/Å²; cells of one median edge
/// still held about one.
constexpr double cell_in_median_radii = 3.0 / near_duplicate_fraction;

/// A vertex is paired with a neighbouring cell's vertices only when it lies within this many times its radius of
/// that cell along every axis the cell is offset in (plus vertex_grid's bound on the rounding of a cell's faces):
/// a partner lies within the radius, so a farther vertex has none there. Most vertices of a cell 30 radii wide are
/// paired within their own cell only.
constexpr double neighbour_reach_in_radii = 2.0;

/// A sparse grid of cubic cells over the vertices that take part, as (cell key, vertex) entries sorted by key.
class vertex_grid {
 public:
  /// `cell_in_median`: the cell edge in median radii (for radii that are a fraction of the edges around them).
  vertex_grid(const surface_mesh& mesh, const std::vector<double>& radii, double cell_in_median = cell_in_median_radii)
      : positions_(mesh.positions), radii_(radii) {
    vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            std::numeric_limits<double>::infinity()};
    vec3 hi = -lo;
    std::vector<double> taking_part;
    for (std::size_t v = 0; v < radii.size(); ++v) {
      if (!(radii[v] > 0)) continue;
      taking_part.push_back(radii[v]);
      for (int axis = 0; axis < 3; ++axis) {
        lo[axis] = std::min(lo[axis], mesh.positions[v][axis]);
        hi[axis] = std::max(hi[axis], mesh.positions[v][axis]);
      }
    }
    if (taking_part.empty()) return;
    const double largest_radius = *std::max_element(taking_part.begin(), taking_part.end());
    const auto middle = taking_part.begin() + static_cast<std::ptrdiff_t>(taking_part.size() / 2);
    std::nth_element(taking_part.begin(), middle, taking_part.end());
    origin_ = lo;
    // At least the largest radius, so that a pair within it lies in the same or adjacent cells; larger when the
    // coordinates would not fit the key.
    const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    cell_size_ = std::max({largest_radius, cell_in_median * *middle,
                           extent / static_cast<double>(max_cell_coordinate - 1)});
    // cell_of's quotient and a face's position are each within a few ulps of the largest coordinate.
    const double largest_coordinate = std::max({std::fabs(lo.x), std::fabs(lo.y), std::fabs(lo.z), std::fabs(hi.x),
                                                std::fabs(hi.y), std::fabs(hi.z)});
    face_rounding_ = 64 * std::numeric_limits<double>::epsilon() * (largest_coordinate + extent + cell_size_);
    for (std::size_t v = 0; v < radii.size(); ++v) {
      if (radii[v] > 0) entries_.emplace_back(key(cell_of(mesh.positions[v])), static_cast<std::uint32_t>(v));
    }
    std::sort(entries_.begin(), entries_.end());
    for (std::size_t e = 0; e < entries_.size(); ++e) {
      if (e == 0 || entries_[e].first != entries_[e - 1].first) cell_starts_.push_back(e);
    }
    cell_starts_.push_back(entries_.size());
  }

  std::size_t cell_count() const { return cell_starts_.empty() ? 0 : cell_starts_.size() - 1; }

  /// Calls visit(a, b) once for every pair of vertices in occupied cell `c` and the cells next to it that may lie
  /// within a's radius of each other: the pairs within c, and with the 13 neighbours whose offset is positive in the
  /// first non-zero axis (each pair of adjacent cells is then met once) those whose vertex a of c lies near enough to
  /// the neighbour (neighbour_reach_in_radii). `near_sides` is scratch.
  template <class Visit>
  void for_each_pair_from(std::size_t c, std::vector<std::uint8_t>& near_sides, Visit&& visit) const {
    const std::size_t begin = cell_starts_[c], end = cell_starts_[c + 1];
    for (std::size_t i = begin; i < end; ++i) {
      for (std::size_t j = i + 1; j < end; ++j) visit(entries_[i].second, entries_[j].second);
    }
    const std::array<std::int64_t, 3> at = coordinates(entries_[begin].first);
    std::uint8_t any_near = 0;
    near_sides.clear();
    for (std::size_t i = begin; i < end; ++i) {
      near_sides.push_back(sides_near(at, entries_[i].second));
      any_near |= near_sides.back();
    }
    if (any_near == 0) return;
    for (std::int64_t dx = 0; dx <= 1; ++dx) {
      for (std::int64_t dy = dx == 0 ? 0 : -1; dy <= 1; ++dy) {
        for (std::int64_t dz = dx == 0 && dy == 0 ? 1 : -1; dz <= 1; ++dz) {
          const std::uint8_t towards = sides_towards({dx, dy, dz});
          if ((any_near & towards) != towards) continue;
          const std::array<std::int64_t, 3> n{at[0] + dx, at[1] + dy, at[2] + dz};
          if (!inside(n)) continue;
          const std::uint64_t k = key(n);
          auto it = std::lower_bound(entries_.begin(), entries_.end(), std::pair<std::uint64_t, std::uint32_t>{k, 0});
          for (; it != entries_.end() && it->first == k; ++it) {
            for (std::size_t i = begin; i < end; ++i) {
              if ((near_sides[i - begin] & towards) == towards) visit(entries_[i].second, it->second);
            }
          }
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
  /// Bit 2·axis (low side) or 2·axis + 1 (high side) set when vertex v, in the cell at `at`, lies within
  /// neighbour_reach_in_radii × its radius (plus face_rounding_) of that face of the cell, or outside it (where
  /// cell_of clamped).
  std::uint8_t sides_near(const std::array<std::int64_t, 3>& at, std::uint32_t v) const {
    const double reach = neighbour_reach_in_radii * radii_[v] + face_rounding_;
    std::uint8_t sides = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double low = origin_[axis] + static_cast<double>(at[axis]) * cell_size_;
      const double p = positions_[v][axis];
      if (p - low < reach) sides |= std::uint8_t(1U << (2 * axis));
      if (low + cell_size_ - p < reach) sides |= std::uint8_t(1U << (2 * axis + 1));
    }
    return sides;
  }
  /// The sides_near bits a vertex needs for the cell at `offset` (each component −1, 0 or 1) from its own.
  static std::uint8_t sides_towards(const std::array<std::int64_t, 3>& offset) {
    std::uint8_t sides = 0;
    for (int axis = 0; axis < 3; ++axis) {
      if (offset[axis] < 0) sides |= std::uint8_t(1U << (2 * axis));
      if (offset[axis] > 0) sides |= std::uint8_t(1U << (2 * axis + 1));
    }
    return sides;
  }
  static bool inside(const std::array<std::int64_t, 3>& c) {
    return std::all_of(c.begin(), c.end(), [](std::int64_t x) { return x >= 0 && x <= max_cell_coordinate; });
  }
  static std::uint64_t key(const std::array<std::int64_t, 3>& c) {
    return (static_cast<std::uint64_t>(c[0]) << (2 * cell_bits)) | (static_cast<std::uint64_t>(c[1]) << cell_bits) |
           static_cast<std::uint64_t>(c[2]);
  }
  static std::array<std::int64_t, 3> coordinates(std::uint64_t key) {
    const std::uint64_t mask = (std::uint64_t{1} << cell_bits) - 1;
    return {static_cast<std::int64_t>(key >> (2 * cell_bits)), static_cast<std::int64_t>((key >> cell_bits) & mask),
            static_cast<std::int64_t>(key & mask)};
  }

  const std::vector<vec3>& positions_;
  const std::vector<double>& radii_;
  vec3 origin_{};
  double cell_size_ = 1;
  double face_rounding_ = 0;  ///< Å: bound on the rounding of where a point's cell puts it (see sides_near)
  std::vector<std::pair<std::uint64_t, std::uint32_t>> entries_;
  std::vector<std::size_t> cell_starts_;  ///< first entry of each occupied cell, then entries_.size()
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
      grid.cell_count(), std::size_t{0},
      [&](std::size_t begin, std::size_t end) {
        std::size_t pairs = 0;
        std::vector<std::uint8_t> near_sides;
        for (std::size_t c = begin; c < end; ++c) {
          grid.for_each_pair_from(c, near_sides, [&](std::uint32_t a, std::uint32_t b) {
            const double within = std::min(radii[a], radii[b]);
            if (squared_norm(mesh.positions[a] - mesh.positions[b]) < within * within &&
                !share_an_edge(mesh, fans, a, b)) {
              ++pairs;
            }
          });
        }
        return pairs;
      },
      [](std::size_t total, std::size_t part) { return total + part; });
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> vertex_pairs_closer_than(const surface_mesh& mesh,
                                                                               double radius) {
  const std::vector<double> radii(mesh.positions.size(), radius);
  const vertex_grid grid(mesh, radii, 1.0);  // cells one radius wide: every vertex has the same radius
  using pair_list = std::vector<std::pair<std::uint32_t, std::uint32_t>>;
  pair_list pairs = deterministic_reduce(
      grid.cell_count(), pair_list{},
      [&](std::size_t begin, std::size_t end) {
        pair_list found;
        std::vector<std::uint8_t> near_sides;
        for (std::size_t c = begin; c < end; ++c) {
          grid.for_each_pair_from(c, near_sides, [&](std::uint32_t a, std::uint32_t b) {
            if (squared_norm(mesh.positions[a] - mesh.positions[b]) < radius * radius) {
              found.emplace_back(std::min(a, b), std::max(a, b));
            }
          });
        }
        return found;
      },
      [](pair_list total, const pair_list& part) {
        total.insert(total.end(), part.begin(), part.end());
        return total;
      });
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace tracemesh::detail
