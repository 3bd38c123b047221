#include "core/detail/remesh_intersections.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>

#include "core/detail/triangle_intersection.hpp"

namespace tracemesh::detail {
namespace {

struct box {
  vec3 lo, hi;
};

box triangle_box(const std::vector<vec3>& positions, const std::array<std::uint32_t, 3>& t) {
  box b{positions[t[0]], positions[t[0]]};
  for (int k = 1; k < 3; ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      b.lo[axis] = std::min(b.lo[axis], positions[t[k]][axis]);
      b.hi[axis] = std::max(b.hi[axis], positions[t[k]][axis]);
    }
  }
  return b;
}

bool boxes_overlap(const box& a, const box& b) {
  for (int axis = 0; axis < 3; ++axis) {
    if (a.lo[axis] > b.hi[axis] || b.lo[axis] > a.hi[axis]) return false;
  }
  return true;
}

/// Cell edge relative to the mean largest extent of the triangles' boxes: a triangle overlaps a few cells.
constexpr double cell_factor = 2.0;
/// Grid entries allowed per triangle on average; past it the cell doubles (a few huge triangles).
constexpr std::size_t max_entries_per_triangle = 16;
/// Cell indices take 21 bits per axis so that a key packs into 64 bits.
constexpr int key_bits = 21;
constexpr std::int64_t max_cell_index = (std::int64_t{1} << key_bits) - 1;

using cell_index = std::array<std::int64_t, 3>;

std::uint64_t pack(const cell_index& c) {
  return (static_cast<std::uint64_t>(c[0]) << (2 * key_bits)) | (static_cast<std::uint64_t>(c[1]) << key_bits) |
         static_cast<std::uint64_t>(c[2]);
}

/// A sparse uniform grid: every triangle is entered in each cell its box overlaps.
class triangle_grid {
 public:
  explicit triangle_grid(const std::vector<box>& boxes) {
    box all = boxes.front();
    double extent_sum = 0;
    for (const box& b : boxes) {
      for (int axis = 0; axis < 3; ++axis) {
        all.lo[axis] = std::min(all.lo[axis], b.lo[axis]);
        all.hi[axis] = std::max(all.hi[axis], b.hi[axis]);
      }
      extent_sum += std::max({b.hi.x - b.lo.x, b.hi.y - b.lo.y, b.hi.z - b.lo.z});
    }
    origin_ = all.lo;
    const double span = std::max({all.hi.x - all.lo.x, all.hi.y - all.lo.y, all.hi.z - all.lo.z});
    cell_ = std::max({cell_factor * extent_sum / static_cast<double>(boxes.size()),
                      span / static_cast<double>(max_cell_index - 1), 1e-9});
    while (entry_count(boxes) > max_entries_per_triangle * boxes.size() + 64) cell_ *= 2;
    fill(boxes);
  }

  /// The cell holding point p.
  cell_index cell_of(const vec3& p) const {
    cell_index c;
    for (int axis = 0; axis < 3; ++axis) {
      c[axis] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((p[axis] - origin_[axis]) / cell_)), 0,
                                         max_cell_index);
    }
    return c;
  }

  struct entry {
    std::uint64_t key;
    std::uint32_t triangle;
    friend bool operator<(const entry& a, const entry& b) {
      return a.key != b.key ? a.key < b.key : a.triangle < b.triangle;
    }
  };
  /// Entries sorted by (cell, triangle); each cell's triangles are contiguous.
  const std::vector<entry>& entries() const { return entries_; }
  /// Start of each cell's run in entries(), plus entries().size() at the end.
  const std::vector<std::size_t>& cell_starts() const { return cell_starts_; }

 private:
  std::size_t cells_overlapped(const box& b) const {
    const cell_index lo = cell_of(b.lo), hi = cell_of(b.hi);
    return static_cast<std::size_t>((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1));
  }
  std::size_t entry_count(const std::vector<box>& boxes) const {
    std::size_t count = 0;
    for (const box& b : boxes) count += cells_overlapped(b);
    return count;
  }
  void fill(const std::vector<box>& boxes) {
    std::vector<std::size_t> offsets(boxes.size() + 1, 0);
    for (std::size_t t = 0; t < boxes.size(); ++t) offsets[t + 1] = offsets[t] + cells_overlapped(boxes[t]);
    entries_.resize(offsets.back());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, boxes.size()), [&](const auto& range) {
      for (std::size_t t = range.begin(); t != range.end(); ++t) {
        const cell_index lo = cell_of(boxes[t].lo), hi = cell_of(boxes[t].hi);
        std::size_t out = offsets[t];
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
          for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
            for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
              entries_[out++] = {pack({x, y, z}), static_cast<std::uint32_t>(t)};
            }
          }
        }
      }
    });
    tbb::parallel_sort(entries_.begin(), entries_.end());
    for (std::size_t n = 0; n < entries_.size(); ++n) {
      if (n == 0 || entries_[n].key != entries_[n - 1].key) cell_starts_.push_back(n);
    }
    cell_starts_.push_back(entries_.size());
  }

  double cell_ = 1;
  vec3 origin_;
  std::vector<entry> entries_;
  std::vector<std::size_t> cell_starts_;
};

}  // namespace

std::vector<triangle_pair> find_intersecting_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                                   const std::vector<std::uint8_t>& groups) {
  const auto known_apart = [&](std::uint32_t s, std::uint32_t t) {
    return !groups.empty() && groups[s] != 0 && groups[s] == groups[t];
  };
  const std::vector<vec3>& positions = mesh.positions;
  const auto& triangles = mesh.triangles;
  if (triangles.size() < 2) return {};
  std::vector<box> boxes(triangles.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size()), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) boxes[t] = triangle_box(positions, triangles[t]);
  });
  const triangle_grid grid(boxes);
  const auto& entries = grid.entries();
  const auto& starts = grid.cell_starts();

  tbb::enumerable_thread_specific<std::vector<triangle_pair>> found;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, starts.size() - 1), [&](const auto& range) {
    auto& out = found.local();
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      const std::uint64_t key = entries[starts[c]].key;
      for (std::size_t i = starts[c]; i < starts[c + 1]; ++i) {
        const std::uint32_t s = entries[i].triangle;
        if (defects[s] != triangle_defect::none) continue;
        for (std::size_t j = i + 1; j < starts[c + 1]; ++j) {
          const std::uint32_t t = entries[j].triangle;
          if (known_apart(s, t)) continue;
          if (defects[t] != triangle_defect::none || !boxes_overlap(boxes[s], boxes[t])) continue;
          // Test each pair once: in the cell holding the lowest corner of the two boxes' intersection.
          const vec3 corner{std::max(boxes[s].lo.x, boxes[t].lo.x), std::max(boxes[s].lo.y, boxes[t].lo.y),
                            std::max(boxes[s].lo.z, boxes[t].lo.z)};
          if (pack(grid.cell_of(corner)) != key) continue;
          if (mesh_triangles_intersect(positions, triangles[s], triangles[t])) out.push_back({s, t});
        }
      }
    }
  });
  std::vector<triangle_pair> pairs;
  found.combine_each(
      [&](const std::vector<triangle_pair>& part) { pairs.insert(pairs.end(), part.begin(), part.end()); });
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

std::vector<std::uint32_t> find_offending_triangles(const surface_mesh& mesh, const std::vector<std::uint8_t>& groups) {
  const std::vector<triangle_defect> defects = classify_triangles(mesh);
  std::vector<std::uint32_t> offending;
  for (std::uint32_t t = 0; t < defects.size(); ++t) {
    if (defects[t] != triangle_defect::none) offending.push_back(t);
  }
  for (const triangle_pair& pair : find_intersecting_pairs(mesh, defects, groups)) {
    offending.insert(offending.end(), pair.begin(), pair.end());
  }
  std::sort(offending.begin(), offending.end());
  offending.erase(std::unique(offending.begin(), offending.end()), offending.end());
  return offending;
}

}  // namespace tracemesh::detail
