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

/// Uniform grid over triangle bounding-box centres. The cell is at least as large as every box, so two boxes that
/// overlap have their centres in the same or in adjacent cells.
class triangle_grid {
 public:
  static constexpr int key_bits = 21;

  explicit triangle_grid(const std::vector<box>& boxes) {
    vec3 lo = boxes.front().lo, hi = boxes.front().hi;
    double largest = 0;
    for (const box& b : boxes) {
      for (int axis = 0; axis < 3; ++axis) {
        lo[axis] = std::min(lo[axis], b.lo[axis]);
        hi[axis] = std::max(hi[axis], b.hi[axis]);
        largest = std::max(largest, b.hi[axis] - b.lo[axis]);
      }
    }
    const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    const double max_cells = static_cast<double>((1 << key_bits) - 4);
    // Slightly larger than every box, so that rounding of the centres cannot separate overlapping boxes.
    cell_ = std::max({largest * (1 + 1e-9) + 1e-12, extent / max_cells, 1e-6});
    origin_ = lo;
    entries_.resize(boxes.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, boxes.size()), [&](const auto& range) {
      for (std::size_t t = range.begin(); t != range.end(); ++t) {
        entries_[t] = {key_of((boxes[t].lo + boxes[t].hi) * 0.5), static_cast<std::uint32_t>(t)};
      }
    });
    tbb::parallel_sort(entries_.begin(), entries_.end());
    for (std::size_t n = 0; n < entries_.size(); ++n) {
      if (cells_.empty() || cells_.back().key != entries_[n].key) cells_.push_back({entries_[n].key, n, n});
      cells_.back().end = n + 1;
    }
  }

  struct entry {
    std::uint64_t key;
    std::uint32_t triangle;
    friend bool operator<(const entry& a, const entry& b) {
      return a.key != b.key ? a.key < b.key : a.triangle < b.triangle;
    }
  };
  struct cell {
    std::uint64_t key;
    std::size_t begin, end;  ///< range in entries()
  };
  const std::vector<cell>& cells() const { return cells_; }
  const std::vector<entry>& entries() const { return entries_; }

  /// The cells adjacent to `c` (26-neighbourhood) whose key is larger, so each pair of cells is visited once.
  void later_neighbours(const cell& c, std::vector<const cell*>& out) const {
    out.clear();
    const std::uint64_t mask = (1ULL << key_bits) - 1;
    const std::int64_t ix = static_cast<std::int64_t>(c.key >> (2 * key_bits));
    const std::int64_t iy = static_cast<std::int64_t>((c.key >> key_bits) & mask);
    const std::int64_t iz = static_cast<std::int64_t>(c.key & mask);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          if (ix + dx < 0 || iy + dy < 0 || iz + dz < 0) continue;
          const std::uint64_t key = pack(ix + dx, iy + dy, iz + dz);
          if (key <= c.key) continue;
          const auto found = std::lower_bound(cells_.begin(), cells_.end(), key,
                                              [](const cell& x, std::uint64_t k) { return x.key < k; });
          if (found != cells_.end() && found->key == key) out.push_back(&*found);
        }
      }
    }
  }

 private:
  static std::uint64_t pack(std::int64_t ix, std::int64_t iy, std::int64_t iz) {
    return (static_cast<std::uint64_t>(ix) << (2 * key_bits)) | (static_cast<std::uint64_t>(iy) << key_bits) |
           static_cast<std::uint64_t>(iz);
  }
  std::uint64_t key_of(const vec3& p) const {
    const auto index = [&](int axis) {
      return static_cast<std::int64_t>(std::floor((p[axis] - origin_[axis]) / cell_)) + 1;  // +1: room for −1
    };
    return pack(index(0), index(1), index(2));
  }

  double cell_ = 1;
  vec3 origin_;
  std::vector<entry> entries_;
  std::vector<cell> cells_;
};

}  // namespace

std::vector<triangle_pair> find_intersecting_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  const std::vector<vec3>& positions = mesh.positions;
  const auto& triangles = mesh.triangles;
  if (triangles.size() < 2) return {};
  std::vector<box> boxes(triangles.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size()), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) boxes[t] = triangle_box(positions, triangles[t]);
  });
  const triangle_grid grid(boxes);
  const auto& cells = grid.cells();
  const auto& entries = grid.entries();

  tbb::enumerable_thread_specific<std::vector<triangle_pair>> found;
  tbb::enumerable_thread_specific<std::vector<const triangle_grid::cell*>> neighbour_lists;
  const auto test = [&](std::uint32_t s, std::uint32_t t, std::vector<triangle_pair>& out) {
    if (defects[s] != triangle_defect::none || defects[t] != triangle_defect::none) return;
    if (!boxes_overlap(boxes[s], boxes[t])) return;
    if (mesh_triangles_intersect(positions, triangles[s], triangles[t])) out.push_back({std::min(s, t), std::max(s, t)});
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size()), [&](const auto& range) {
    auto& out = found.local();
    auto& neighbours = neighbour_lists.local();
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      const auto& cell = cells[c];
      grid.later_neighbours(cell, neighbours);
      for (std::size_t i = cell.begin; i < cell.end; ++i) {
        const std::uint32_t s = entries[i].triangle;
        for (std::size_t j = i + 1; j < cell.end; ++j) test(s, entries[j].triangle, out);
        for (const auto* other : neighbours) {
          for (std::size_t j = other->begin; j < other->end; ++j) test(s, entries[j].triangle, out);
        }
      }
    }
  });
  std::vector<triangle_pair> pairs;
  found.combine_each([&](const std::vector<triangle_pair>& part) { pairs.insert(pairs.end(), part.begin(), part.end()); });
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

std::vector<std::uint32_t> find_offending_triangles(const surface_mesh& mesh) {
  const std::vector<triangle_defect> defects = classify_triangles(mesh);
  std::vector<std::uint32_t> offending;
  for (std::uint32_t t = 0; t < defects.size(); ++t) {
    if (defects[t] != triangle_defect::none) offending.push_back(t);
  }
  for (const triangle_pair& pair : find_intersecting_pairs(mesh, defects)) {
    offending.insert(offending.end(), pair.begin(), pair.end());
  }
  std::sort(offending.begin(), offending.end());
  offending.erase(std::unique(offending.begin(), offending.end()), offending.end());
  return offending;
}

}  // namespace tracemesh::detail
