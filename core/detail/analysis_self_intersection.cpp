#include "core/detail/analysis_self_intersection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include "core/detail/analysis_parallel.hpp"
#include "core/detail/triangle_intersection.hpp"

namespace tracemesh::detail {
namespace {

struct bounds {
  vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  vec3 hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity()};

  void include(const vec3& p) {
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
    }
  }
  void include(const bounds& other) {
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], other.lo[axis]);
      hi[axis] = std::max(hi[axis], other.hi[axis]);
    }
  }
  double largest_extent() const { return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}); }
};

bounds triangle_bounds(const surface_mesh& mesh, std::uint32_t t) {
  bounds box;
  for (const std::uint32_t v : mesh.triangles[t]) box.include(mesh.positions[v]);
  return box;
}

/// Cell indices take 21 bits per axis so that a cell key packs into 64 bits.
constexpr int cell_index_bits = 21;
constexpr std::uint32_t max_cell_index = (1u << cell_index_bits) - 1;

using cell_coordinates = std::array<std::uint32_t, 3>;

class sparse_grid {
 public:
  sparse_grid(const vec3& origin, double cell_size) : origin_(origin), cell_size_(cell_size) {}

  /// Monotone in `coordinate`, so a box's cells run from index(lo) to index(hi) on each axis.
  std::uint32_t index(double coordinate, int axis) const {
    const double cell = std::floor((coordinate - origin_[axis]) / cell_size_);
    return static_cast<std::uint32_t>(std::clamp(cell, 0.0, static_cast<double>(max_cell_index)));
  }

  cell_coordinates first_cell(const bounds& box) const {
    return {index(box.lo.x, 0), index(box.lo.y, 1), index(box.lo.z, 2)};
  }
  cell_coordinates last_cell(const bounds& box) const {
    return {index(box.hi.x, 0), index(box.hi.y, 1), index(box.hi.z, 2)};
  }

  std::uint64_t cells_overlapped(const bounds& box) const {
    const cell_coordinates first = first_cell(box), last = last_cell(box);
    std::uint64_t cells = 1;
    for (int axis = 0; axis < 3; ++axis) cells *= std::uint64_t{last[axis] - first[axis]} + 1;  // < 2⁶³
    return cells;
  }

  static std::uint64_t key(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return (std::uint64_t{x} << (2 * cell_index_bits)) | (std::uint64_t{y} << cell_index_bits) | z;
  }
  static cell_coordinates coordinates(std::uint64_t key) {
    return {static_cast<std::uint32_t>(key >> (2 * cell_index_bits)),
            static_cast<std::uint32_t>((key >> cell_index_bits) & max_cell_index),
            static_cast<std::uint32_t>(key & max_cell_index)};
  }

 private:
  vec3 origin_;
  double cell_size_;
};

struct grid_entry {
  std::uint64_t cell;
  std::uint32_t triangle;
  friend bool operator<(const grid_entry& a, const grid_entry& b) {
    return a.cell < b.cell || (a.cell == b.cell && a.triangle < b.triangle);
  }
};

/// The triangles to test and the extent of their boxes.
struct tested_set {
  std::size_t triangles = 0;
  double extent_sum = 0;
  bounds domain;
};

tested_set survey(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  return deterministic_reduce(
      mesh.triangles.size(), tested_set{},
      [&](std::size_t begin, std::size_t end) {
        tested_set part;
        for (std::size_t t = begin; t < end; ++t) {
          if (defects[t] != triangle_defect::none) continue;
          const bounds box = triangle_bounds(mesh, static_cast<std::uint32_t>(t));
          ++part.triangles;
          part.extent_sum += box.largest_extent();
          part.domain.include(box);
        }
        return part;
      },
      [](tested_set total, const tested_set& part) {
        total.triangles += part.triangles;
        total.extent_sum += part.extent_sum;
        total.domain.include(part.domain);
        return total;
      });
}

std::uint64_t saturating_add(std::uint64_t a, std::uint64_t b) {
  return a > std::numeric_limits<std::uint64_t>::max() - b ? std::numeric_limits<std::uint64_t>::max() : a + b;
}

/// Grid entries of each chunk of triangles (saturating).
std::vector<std::uint64_t> entries_per_chunk(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                             const sparse_grid& grid) {
  std::vector<std::uint64_t> counts(chunk_count(mesh.triangles.size()), 0);
  for_each_chunk(mesh.triangles.size(), [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    std::uint64_t count = 0;
    for (std::size_t t = begin; t < end; ++t) {
      if (defects[t] != triangle_defect::none) continue;
      count = saturating_add(count, grid.cells_overlapped(triangle_bounds(mesh, static_cast<std::uint32_t>(t))));
    }
    counts[chunk] = count;
  });
  return counts;
}

/// The grid: cells of grid_cell_factor × the mean box extent, at most 2²¹ per axis, doubled until the entries fit
/// the budget. Returns it with the entry count of each chunk of triangles.
sparse_grid choose_grid(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                        const tested_set& tested, std::vector<std::uint64_t>& chunk_entries) {
  const double mean_extent = tested.extent_sum / static_cast<double>(tested.triangles);
  double cell_size = std::max(grid_cell_factor * mean_extent,
                              tested.domain.largest_extent() / static_cast<double>(max_cell_index));
  if (!(cell_size > 0)) cell_size = 1;  // unreachable for non-degenerate triangles; keeps the division defined
  const std::uint64_t budget = max_grid_entries_per_triangle * std::uint64_t{tested.triangles} + 1024;
  for (;;) {
    const sparse_grid grid(tested.domain.lo, cell_size);
    chunk_entries = entries_per_chunk(mesh, defects, grid);
    std::uint64_t total = 0;
    for (const std::uint64_t count : chunk_entries) total = saturating_add(total, count);
    if (total <= budget) return grid;
    cell_size *= 2;
  }
}

std::vector<grid_entry> fill_grid(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                  const sparse_grid& grid, const std::vector<std::uint64_t>& chunk_entries) {
  std::vector<std::size_t> chunk_offsets(chunk_entries.size() + 1, 0);
  for (std::size_t chunk = 0; chunk < chunk_entries.size(); ++chunk) {
    chunk_offsets[chunk + 1] = chunk_offsets[chunk] + static_cast<std::size_t>(chunk_entries[chunk]);
  }
  std::vector<grid_entry> entries(chunk_offsets.back());
  for_each_chunk(mesh.triangles.size(), [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    std::size_t next = chunk_offsets[chunk];
    for (std::size_t t = begin; t < end; ++t) {
      if (defects[t] != triangle_defect::none) continue;
      const bounds box = triangle_bounds(mesh, static_cast<std::uint32_t>(t));
      const cell_coordinates first = grid.first_cell(box), last = grid.last_cell(box);
      for (std::uint32_t x = first[0]; x <= last[0]; ++x) {
        for (std::uint32_t y = first[1]; y <= last[1]; ++y) {
          for (std::uint32_t z = first[2]; z <= last[2]; ++z) {
            entries[next++] = {sparse_grid::key(x, y, z), static_cast<std::uint32_t>(t)};
          }
        }
      }
    }
  });
  tbb::parallel_sort(entries.begin(), entries.end());
  return entries;
}

/// Start of each run of entries sharing a cell, plus the end.
std::vector<std::size_t> cell_starts(const std::vector<grid_entry>& entries) {
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (i == 0 || entries[i].cell != entries[i - 1].cell) starts.push_back(i);
  }
  starts.push_back(entries.size());
  return starts;
}

struct candidate {
  bounds box;
  std::uint32_t triangle;
};

/// Intersecting pairs whose boxes' common part starts in this cell (entries[begin, end) share the cell).
std::size_t count_pairs_in_cell(const surface_mesh& mesh, const sparse_grid& grid,
                                const std::vector<grid_entry>& entries, std::size_t begin, std::size_t end,
                                std::vector<candidate>& candidates) {
  const cell_coordinates cell = sparse_grid::coordinates(entries[begin].cell);
  candidates.clear();
  for (std::size_t i = begin; i < end; ++i) {
    candidates.push_back({triangle_bounds(mesh, entries[i].triangle), entries[i].triangle});
  }
  std::sort(candidates.begin(), candidates.end(), [](const candidate& a, const candidate& b) {
    return a.box.lo.x < b.box.lo.x || (a.box.lo.x == b.box.lo.x && a.triangle < b.triangle);
  });
  std::size_t count = 0;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const bounds& a = candidates[i].box;
    // Sorted by lo.x: the boxes overlap in x while the next one starts before this one ends.
    for (std::size_t j = i + 1; j < candidates.size() && candidates[j].box.lo.x <= a.hi.x; ++j) {
      const bounds& b = candidates[j].box;
      if (b.lo.y > a.hi.y || a.lo.y > b.hi.y || b.lo.z > a.hi.z || a.lo.z > b.hi.z) continue;
      const bool lowest_common_cell = grid.index(b.lo.x, 0) == cell[0] &&
                                      grid.index(std::max(a.lo.y, b.lo.y), 1) == cell[1] &&
                                      grid.index(std::max(a.lo.z, b.lo.z), 2) == cell[2];
      if (!lowest_common_cell) continue;
      if (mesh_triangles_intersect(mesh.positions, mesh.triangles[candidates[i].triangle],
                                   mesh.triangles[candidates[j].triangle])) {
        ++count;
      }
    }
  }
  return count;
}

}  // namespace

std::size_t count_intersecting_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  const tested_set tested = survey(mesh, defects);
  if (tested.triangles < 2) return 0;
  std::vector<std::uint64_t> chunk_entries;
  const sparse_grid grid = choose_grid(mesh, defects, tested, chunk_entries);
  const std::vector<grid_entry> entries = fill_grid(mesh, defects, grid, chunk_entries);
  const std::vector<std::size_t> starts = cell_starts(entries);
  const std::size_t cells = starts.size() - 1;
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, cells, 64), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& range, std::size_t count) {
        std::vector<candidate> candidates;
        for (std::size_t cell = range.begin(); cell != range.end(); ++cell) {
          count += count_pairs_in_cell(mesh, grid, entries, starts[cell], starts[cell + 1], candidates);
        }
        return count;
      },
      std::plus<>());
}

}  // namespace tracemesh::detail
