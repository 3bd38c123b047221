#include "core/analysis/analysis_moved_triangles.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "core/analysis/analysis_fan_pairs.hpp"
#include "core/analysis/analysis_geometry.hpp"
#include "core/field/gaussian_field.hpp"

namespace tracemesh::detail {
namespace {

/// failing_moved_triangles() tests this many moved triangles at a time: the raw 1k4r_capsid at 1 v/Å² moves about a
/// million in its short-edge collapses, and tested at once they raised the job's peak from 1,047 to 1,321 MB
/// (2¹⁵ at a time: 992 MB, but 2 s slower, every batch scanning the whole mesh for the triangles near it).
constexpr std::size_t moved_triangles_per_batch = std::size_t{1} << 17;

/// The sorted triangles of a list, each once.
std::vector<std::uint32_t> sorted_once(std::vector<std::uint32_t> triangles) {
  std::sort(triangles.begin(), triangles.end());
  triangles.erase(std::unique(triangles.begin(), triangles.end()), triangles.end());
  return triangles;
}

/// The triangles of `reported` (sorted) that are degenerate or meet another triangle of `nearby` (sorted, `tested`
/// included) in a pair with a triangle of `tested` (sorted): the pairs of other triangles of `nearby` are not tested.
std::vector<std::uint32_t> failing_among(const surface_mesh& mesh, const std::vector<std::uint32_t>& reported,
                                         const std::vector<std::uint32_t>& tested,
                                         const std::vector<std::uint32_t>& nearby) {
  // The nearby triangles as a mesh of their own; group 1 (tested before, not against each other) for the others.
  surface_mesh local;
  std::vector<std::uint8_t> groups;
  std::unordered_map<std::uint32_t, std::uint32_t> local_vertex;
  for (const std::uint32_t f : nearby) {
    std::array<std::uint32_t, 3> t{};
    for (std::size_t i = 0; i < 3; ++i) {
      const std::uint32_t v = mesh.triangles[f][i];
      const auto [it, added] = local_vertex.try_emplace(v, static_cast<std::uint32_t>(local.positions.size()));
      if (added) local.positions.push_back(mesh.positions[v]);
      t[i] = it->second;
    }
    local.triangles.push_back(t);
    groups.push_back(std::binary_search(tested.begin(), tested.end(), f) ? 0 : 1);
  }
  const std::vector<triangle_defect> defects = classify_triangles(local);
  std::vector<std::uint32_t> failing;
  const auto add_if_reported = [&](std::uint32_t local_triangle) {
    const std::uint32_t f = nearby[local_triangle];
    if (std::binary_search(reported.begin(), reported.end(), f)) failing.push_back(f);
  };
  for (std::uint32_t t = 0; t < defects.size(); ++t) {
    if (defects[t] != triangle_defect::none && groups[t] == 0) add_if_reported(t);
  }
  for (const auto& pair : find_intersecting_pairs(local, defects, groups)) {
    for (const std::uint32_t t : pair) add_if_reported(t);
  }
  return sorted_once(std::move(failing));
}

}  // namespace

// One parallel pass over the triangles, with the moving boxes hashed in a grid of cells as large as the largest of
// them or of a sample of the mesh's triangles; a bit per hashed cell turns most triangles away before any lookup (on
// 1k4r_capsid at 2 v/Å² the pass looks at ten million triangles for a few thousand moved ones).
std::vector<std::uint32_t> triangles_near(const surface_mesh& mesh, const std::vector<char>& alive,
                                          const std::vector<std::uint32_t>& moving) {
  double cell = 0;
  std::vector<box3> moving_boxes;
  for (const std::uint32_t f : moving) {
    moving_boxes.push_back(bounds_of(mesh.positions, mesh.triangles[f]));
    for (int axis = 0; axis < 3; ++axis) {
      cell = std::max(cell, moving_boxes.back().hi[axis] - moving_boxes.back().lo[axis]);
    }
  }
  if (moving.empty() || !(cell > 0)) return moving;
  // Cells no smaller than the mesh's triangles either (from an even sample of them), so that a triangle spans few.
  const std::size_t stride = std::max<std::size_t>(1, mesh.triangles.size() / 4096);
  for (std::size_t f = 0; f < mesh.triangles.size(); f += stride) {
    const box3 b = bounds_of(mesh.positions, mesh.triangles[f]);
    for (int axis = 0; axis < 3; ++axis) cell = std::max(cell, b.hi[axis] - b.lo[axis]);
  }
  const auto key = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return (static_cast<std::uint64_t>(i) * 73856093u) ^ (static_cast<std::uint64_t>(j) * 19349663u) ^
           (static_cast<std::uint64_t>(k) * 83492791u);
  };
  const double per_cell = 1 / cell;
  const auto index = [per_cell](double x) { return static_cast<std::int64_t>(std::floor(x * per_cell)); };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  for (std::uint32_t m = 0; m < moving_boxes.size(); ++m) {
    const box3& b = moving_boxes[m];
    for (std::int64_t i = index(b.lo.x); i <= index(b.hi.x); ++i) {
      for (std::int64_t j = index(b.lo.y); j <= index(b.hi.y); ++j) {
        for (std::int64_t k = index(b.lo.z); k <= index(b.hi.z); ++k) grid[key(i, j, k)].push_back(m);
      }
    }
  }
  // One bit per hashed cell, at least 64 bits per occupied cell: a clear bit means an empty cell.
  std::size_t bits = 1 << 12;
  while (bits < 64 * grid.size()) bits *= 2;
  std::vector<std::uint64_t> occupied(bits / 64, 0);
  for (const auto& entry : grid) occupied[(entry.first & (bits - 1)) / 64] |= std::uint64_t{1} << (entry.first % 64);
  const auto may_be_occupied = [&](std::uint64_t k) {
    return (occupied[(k & (bits - 1)) / 64] >> (k % 64) & 1) != 0;
  };
  const auto meets_a_moving_box = [&](const box3& b) {
    for (std::int64_t i = index(b.lo.x); i <= index(b.hi.x); ++i) {
      for (std::int64_t j = index(b.lo.y); j <= index(b.hi.y); ++j) {
        for (std::int64_t k = index(b.lo.z); k <= index(b.hi.z); ++k) {
          const std::uint64_t cell_key = key(i, j, k);
          if (!may_be_occupied(cell_key)) continue;
          const auto it = grid.find(cell_key);
          if (it == grid.end()) continue;
          for (const std::uint32_t m : it->second) {
            if (b.meets(moving_boxes[m])) return true;
          }
        }
      }
    }
    return false;
  };
  // Fixed blocks, concatenated in order: the same list whatever the thread count.
  constexpr std::size_t block = 1 << 14;
  const std::size_t count = mesh.triangles.size(), blocks = (count + block - 1) / block;
  std::vector<std::vector<std::uint32_t>> near_in_block(blocks);
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t n) {
    for (auto f = static_cast<std::uint32_t>(n * block); f < std::min(count, (n + 1) * block); ++f) {
      const bool live = alive.empty() || alive[f];
      if (live && meets_a_moving_box(bounds_of(mesh.positions, mesh.triangles[f]))) near_in_block[n].push_back(f);
    }
  });
  std::vector<std::uint32_t> near;
  for (const auto& part : near_in_block) near.insert(near.end(), part.begin(), part.end());
  return near;
}

std::vector<std::uint32_t> failing_moved_triangles(const surface_mesh& mesh, const std::vector<char>& alive,
                                                   std::vector<std::uint32_t> moving) {
  std::vector<std::uint32_t> retest = moving;
  return failing_moved_triangles_again(mesh, alive, std::move(moving), std::move(retest));
}

std::vector<std::uint32_t> failing_moved_triangles_again(const surface_mesh& mesh, const std::vector<char>& alive,
                                                         std::vector<std::uint32_t> moving,
                                                         std::vector<std::uint32_t> retest) {
  moving = sorted_once(std::move(moving));
  retest = sorted_once(std::move(retest));
  // In batches of consecutive triangles, so that the local mesh stays small: each batch is tested against every
  // triangle near it, the other batches' included, so every pair is tested.
  std::vector<std::uint32_t> failing;
  for (std::size_t first = 0; first < retest.size(); first += moved_triangles_per_batch) {
    const std::vector<std::uint32_t> batch(
        retest.begin() + static_cast<std::ptrdiff_t>(first),
        retest.begin() + static_cast<std::ptrdiff_t>(std::min(retest.size(), first + moved_triangles_per_batch)));
    const std::vector<std::uint32_t> found = failing_among(mesh, moving, batch, triangles_near(mesh, alive, batch));
    failing.insert(failing.end(), found.begin(), found.end());
  }
  return sorted_once(std::move(failing));
}

std::vector<std::uint32_t> failing_moved_triangles_among(const surface_mesh& mesh, std::vector<std::uint32_t> moving,
                                                         const std::vector<std::uint32_t>& others) {
  moving = sorted_once(std::move(moving));
  std::vector<std::uint32_t> nearby = moving;
  nearby.insert(nearby.end(), others.begin(), others.end());
  return failing_among(mesh, moving, moving, sorted_once(std::move(nearby)));
}

}  // namespace tracemesh::detail
