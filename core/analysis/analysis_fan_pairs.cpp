#include "core/analysis/analysis_fan_pairs.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

#include "core/analysis/analysis_parallel.hpp"
#include "core/analysis/analysis_predicates.hpp"
#include "core/analysis/triangle_intersection.hpp"

namespace tracemesh::detail {
namespace {

struct point2 {
  double x, y;
};

/// Reusable buffers for one thread's fans.
struct fan_scratch {
  std::vector<fan_corner> corners;
};

/// Reads the fan of `vertex` into scratch.corners; false when one of its triangles is not tested.
bool read_tested_corners(const surface_mesh& mesh, const std::vector<triangle_defect>& defects, std::uint32_t vertex,
                         std::span<const std::uint32_t> around, fan_scratch& scratch) {
  for (const std::uint32_t t : around) {
    if (defects[t] != triangle_defect::none) return false;
  }
  read_fan_corners(mesh, vertex, around, scratch.corners);
  return true;
}

/// The coordinate axis along which the fan's summed face normals are largest: the best bet for a projection
/// that keeps every triangle's orientation (any axis gives a valid proof when the checks pass).
int projection_axis(const surface_mesh& mesh, std::uint32_t vertex, const std::vector<fan_corner>& corners) {
  const vec3& v = mesh.positions[vertex];
  vec3 normal{};
  for (const fan_corner& corner : corners) {
    normal += cross(mesh.positions[corner.next] - v, mesh.positions[corner.prev] - v);
  }
  const double nx = std::abs(normal.x), ny = std::abs(normal.y), nz = std::abs(normal.z);
  if (nx >= ny && nx >= nz) return 0;
  return ny >= nz ? 1 : 2;
}

bool fan_is_embedded_star(const surface_mesh& mesh, const std::vector<triangle_defect>& defects, std::uint32_t vertex,
                          std::span<const std::uint32_t> around, fan_scratch& scratch) {
  if (around.size() < 3) return false;
  if (!read_tested_corners(mesh, defects, vertex, around, scratch) || !corners_form_one_cycle(scratch.corners)) {
    return false;
  }
  const std::vector<fan_corner>& corners = scratch.corners;
  const int axis = projection_axis(mesh, vertex, corners);
  const auto project = [&](std::uint32_t index) {
    const vec3& p = mesh.positions[index];
    return point2{p[(axis + 1) % 3], p[(axis + 2) % 3]};
  };
  const auto orient = [](const point2& a, const point2& b, const point2& c) {
    return orient2d(a.x, a.y, b.x, b.y, c.x, c.y);
  };
  const point2 center = project(vertex);
  // Every projected triangle turns the same way (sign), so each spans a sector of angle in (0, π) from its next
  // to its prev, and consecutive sectors share their boundary ray.
  const int sign = orient(center, project(corners[0].next), project(corners[0].prev));
  if (sign == 0) return false;
  for (const fan_corner& corner : corners) {
    if (orient(center, project(corner.next), project(corner.prev)) != sign) return false;
  }
  // The sectors wind around the center w times, w = the number of half-open sectors (next, prev] containing a
  // fixed ray; with the ray through corner 0's next, w = 1 means they tile the plane once, without overlap.
  // Sectors that start or end on the ray itself are decided by index: the exact predicates would only confirm a
  // zero, on their slow path.
  const std::uint32_t ray_vertex = corners[0].next;
  const point2 ray = project(ray_vertex);
  std::size_t winding = 0;
  for (const fan_corner& corner : corners) {
    if (corner.next == ray_vertex) continue;  // (ray, prev] does not contain the ray
    if (sign * orient(center, project(corner.next), ray) <= 0) continue;
    if (corner.prev == ray_vertex || sign * orient(center, ray, project(corner.prev)) >= 0) ++winding;
  }
  return winding == 1;
}

/// The smallest vertex index shared by triangles t and u (a vertex of t when there is none).
std::uint32_t smallest_shared_vertex(const std::array<std::uint32_t, 3>& t, const std::array<std::uint32_t, 3>& u) {
  std::uint32_t smallest = std::numeric_limits<std::uint32_t>::max();
  for (const std::uint32_t a : t) {
    if (a == u[0] || a == u[1] || a == u[2]) smallest = std::min(smallest, a);
  }
  return smallest;
}

/// Intersecting pairs of the fan of `vertex` whose smallest shared vertex is `vertex`, but those `groups` (when given)
/// says are apart; each is also appended to `found` when given.
std::size_t count_in_fan(const surface_mesh& mesh, const std::vector<triangle_defect>& defects, std::uint32_t vertex,
                         std::span<const std::uint32_t> around, fan_scratch& scratch,
                         const std::vector<std::uint8_t>* groups = nullptr,
                         std::vector<triangle_pair>* found = nullptr) {
  if (fan_is_embedded_star(mesh, defects, vertex, around, scratch)) return 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < around.size(); ++i) {
    if (defects[around[i]] != triangle_defect::none) continue;
    const std::array<std::uint32_t, 3>& t = mesh.triangles[around[i]];
    for (std::size_t j = i + 1; j < around.size(); ++j) {
      if (defects[around[j]] != triangle_defect::none) continue;
      const std::array<std::uint32_t, 3>& u = mesh.triangles[around[j]];
      if (smallest_shared_vertex(t, u) != vertex) continue;  // that pair belongs to a smaller vertex's fan
      if (groups != nullptr && known_apart_groups{*groups}(around[i], around[j])) continue;
      if (!mesh_triangles_intersect(mesh.positions, t, u)) continue;
      ++count;
      if (found != nullptr) found->push_back({std::min(around[i], around[j]), std::max(around[i], around[j])});
    }
  }
  return count;
}

}  // namespace

bool fan_is_embedded_star(const surface_mesh& mesh, const std::vector<triangle_defect>& defects, std::uint32_t vertex,
                          std::span<const std::uint32_t> around) {
  fan_scratch scratch;
  return fan_is_embedded_star(mesh, defects, vertex, around, scratch);
}

std::size_t count_intersecting_fan_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                         const vertex_fans& fans) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh.positions.size(), 1024), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& vertices, std::size_t count) {
        fan_scratch scratch;
        for (std::size_t v = vertices.begin(); v != vertices.end(); ++v) {
          count += count_in_fan(mesh, defects, static_cast<std::uint32_t>(v), fans.around(v), scratch);
        }
        return count;
      },
      std::plus<>());
}

std::vector<triangle_pair> find_intersecting_fan_pairs(const surface_mesh& mesh,
                                                       const std::vector<triangle_defect>& defects,
                                                       const vertex_fans& fans, const std::vector<std::uint8_t>& groups) {
  return deterministic_reduce(
      mesh.positions.size(), std::vector<triangle_pair>{},
      [&](std::size_t begin, std::size_t end) {
        std::vector<triangle_pair> found;
        fan_scratch scratch;
        for (std::size_t v = begin; v < end; ++v) {
          count_in_fan(mesh, defects, static_cast<std::uint32_t>(v), fans.around(v), scratch, &groups, &found);
        }
        return found;
      },
      append_pairs, pair_search_chunk);
}

std::vector<triangle_pair> find_intersecting_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                                   const std::vector<std::uint8_t>& groups) {
  if (mesh.triangles.size() < 2) return {};
  // The certificate's own two passes: pairs sharing no vertex through its grid, the others fan by fan (most fans
  // are proved embedded as a whole).
  std::vector<triangle_pair> pairs = find_intersecting_separate_pairs(mesh, defects, groups);
  const std::vector<triangle_pair> fan_pairs =
      find_intersecting_fan_pairs(mesh, defects, build_vertex_fans(mesh, defects), groups);
  pairs.insert(pairs.end(), fan_pairs.begin(), fan_pairs.end());
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace tracemesh::detail
