#include "core/analysis/analysis_self_intersection.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

#include "core/analysis/analysis_parallel.hpp"
#include "core/analysis/triangle_intersection.hpp"

namespace tracemesh::detail {
namespace {

/// An axis-aligned box in single precision, rounded outward so that it contains the exact box of its triangle.
/// The broad phase only needs conservative boxes; halving their size keeps the per-triangle table small.
struct bounds {
  std::array<float, 3> lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
                          std::numeric_limits<float>::infinity()};
  std::array<float, 3> hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                          -std::numeric_limits<float>::infinity()};

  void include(const vec3& p) {
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], round_down(p[axis]));
      hi[axis] = std::max(hi[axis], round_up(p[axis]));
    }
  }
  void include(const bounds& other) {
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], other.lo[axis]);
      hi[axis] = std::max(hi[axis], other.hi[axis]);
    }
  }
  double largest_extent() const {
    return std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2]});
  }
  /// Closed boxes: touching counts. Bitwise | instead of || avoids six hard-to-predict branches.
  bool overlaps(const bounds& o) const {
    int apart = 0;
    for (int axis = 0; axis < 3; ++axis) {
      apart |= static_cast<int>(o.hi[axis] < lo[axis]) | static_cast<int>(hi[axis] < o.lo[axis]);
    }
    return apart == 0;
  }

 private:
  // v is finite and |v| ≤ max_analysed_coordinate < FLT_MAX. The nearest float is within half a gap of v, so the
  // float one step further out is always on the right side of v (also next to powers of two, where the gap below
  // is half the gap above). Stepping unconditionally avoids an unpredictable branch per coordinate.
  static float round_down(double v) { return next_down(static_cast<float>(v)); }
  static float round_up(double v) { return -next_down(-static_cast<float>(v)); }
  /// The largest float below the finite float f.
  static float next_down(float f) {
    const auto bits = std::bit_cast<std::uint32_t>(f);
    if (bits == 0) return -std::numeric_limits<float>::denorm_min();  // +0
    return std::bit_cast<float>(f > 0 ? bits - 1 : bits + 1);         // −0 becomes −denorm_min
  }
};

bounds triangle_bounds(const surface_mesh& mesh, std::size_t t) {
  bounds box;
  for (const std::uint32_t v : mesh.triangles[t]) box.include(mesh.positions[v]);
  return box;
}

/// The box of every triangle (left empty for untested ones), computed once.
std::vector<bounds> all_triangle_bounds(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  std::vector<bounds> boxes(mesh.triangles.size());
  for_each_chunk(mesh.triangles.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t < end; ++t) {
      if (defects[t] == triangle_defect::none) boxes[t] = triangle_bounds(mesh, t);
    }
  });
  return boxes;
}

using cell_coordinates = std::array<std::uint32_t, 3>;

/// Cells are numbered x-major in the box of the tested triangles; their count must fit in 32 bits so that a
/// (cell, triangle) entry packs into one 64-bit integer.
constexpr double max_grid_cells = 4294967295.0;

class uniform_grid {
 public:
  uniform_grid(const bounds& domain, double cell_size)
      : origin_{domain.lo[0], domain.lo[1], domain.lo[2]}, inverse_cell_size_(1.0 / cell_size) {
    for (int axis = 0; axis < 3; ++axis) {
      cells_[axis] = std::floor((domain.hi[axis] - origin_[axis]) * inverse_cell_size_) + 1;
    }
  }

  double cell_count() const { return cells_[0] * cells_[1] * cells_[2]; }

  /// Monotone in `coordinate` (a subtraction and a multiplication by a positive constant, both rounded), so the
  /// cells of a box run from index(lo) to index(hi) and index(max(a, b)) = max(index(a), index(b)).
  /// coordinate ≥ origin, so the scaled offset is ≥ 0 and truncation is the floor (without a libm call).
  std::uint32_t index(double coordinate, int axis) const {
    const double cell = (coordinate - origin_[axis]) * inverse_cell_size_;
    return static_cast<std::uint32_t>(std::min(cell, cells_[axis] - 1));
  }
  cell_coordinates first_cell(const bounds& box) const {
    return {index(box.lo[0], 0), index(box.lo[1], 1), index(box.lo[2], 2)};
  }
  cell_coordinates last_cell(const bounds& box) const {
    return {index(box.hi[0], 0), index(box.hi[1], 1), index(box.hi[2], 2)};
  }
  std::uint64_t cells_overlapped(const bounds& box) const {
    const cell_coordinates first = first_cell(box), last = last_cell(box);
    std::uint64_t cells = 1;
    for (int axis = 0; axis < 3; ++axis) cells *= std::uint64_t{last[axis] - first[axis]} + 1;  // ≤ 2³²
    return cells;
  }
  std::uint32_t key(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
    return static_cast<std::uint32_t>((std::uint64_t{x} * cell_count_y() + y) * cell_count_z() + z);
  }
  cell_coordinates coordinates(std::uint32_t key) const {
    const std::uint64_t z = key % cell_count_z(), xy = key / cell_count_z();
    return {static_cast<std::uint32_t>(xy / cell_count_y()), static_cast<std::uint32_t>(xy % cell_count_y()),
            static_cast<std::uint32_t>(z)};
  }
  /// Significant bits of a key.
  int key_bits() const { return static_cast<int>(std::ceil(std::log2(cell_count() + 1))); }

 private:
  std::uint64_t cell_count_y() const { return static_cast<std::uint64_t>(cells_[1]); }
  std::uint64_t cell_count_z() const { return static_cast<std::uint64_t>(cells_[2]); }

  vec3 origin_;
  double inverse_cell_size_;
  std::array<double, 3> cells_{};
};

/// A grid entry: the cell key in the high 32 bits, the triangle in the low 32 bits. Sorting entries sorts by cell,
/// then by triangle.
using grid_entry = std::uint64_t;
std::uint32_t cell_of(grid_entry entry) { return static_cast<std::uint32_t>(entry >> 32); }
std::uint32_t triangle_of(grid_entry entry) { return static_cast<std::uint32_t>(entry); }

/// The triangles to test and the extent of their boxes.
struct tested_set {
  std::size_t triangles = 0;
  double extent_sum = 0;
  bounds domain;
};

bool tested(const std::vector<triangle_defect>& defects, std::size_t t) { return defects[t] == triangle_defect::none; }

tested_set survey(const std::vector<bounds>& boxes, const std::vector<triangle_defect>& defects) {
  return deterministic_reduce(
      boxes.size(), tested_set{},
      [&](std::size_t begin, std::size_t end) {
        tested_set part;
        for (std::size_t t = begin; t < end; ++t) {
          if (!tested(defects, t)) continue;
          const bounds& box = boxes[t];
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

/// Grid entries of each chunk of triangles.
std::vector<std::uint64_t> entries_per_chunk(const std::vector<bounds>& boxes,
                                             const std::vector<triangle_defect>& defects, const uniform_grid& grid) {
  std::vector<std::uint64_t> counts(chunk_count(boxes.size()), 0);
  for_each_chunk(boxes.size(), [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    std::uint64_t count = 0;  // ≤ analysis_chunk_size triangles × 2³² cells: no overflow
    for (std::size_t t = begin; t < end; ++t) {
      if (tested(defects, t)) count += grid.cells_overlapped(boxes[t]);
    }
    counts[chunk] = count;
  });
  return counts;
}

std::uint64_t saturating_sum(const std::vector<std::uint64_t>& values) {
  std::uint64_t total = 0;
  for (const std::uint64_t value : values) {
    total = value > std::numeric_limits<std::uint64_t>::max() - total ? std::numeric_limits<std::uint64_t>::max()
                                                                      : total + value;
  }
  return total;
}

/// Cells of grid_cell_factor × the mean box extent, doubled until there are at most 2³² − 1 of them and the
/// entries fit the budget. Returns the grid with the entry count of each chunk of triangles.
uniform_grid choose_grid(const std::vector<bounds>& boxes, const std::vector<triangle_defect>& defects,
                         const tested_set& tested_triangles, std::vector<std::uint64_t>& chunk_entries) {
  double cell_size = grid_cell_factor * tested_triangles.extent_sum / static_cast<double>(tested_triangles.triangles);
  if (!(cell_size > 0)) cell_size = 1;  // unreachable for non-degenerate triangles; keeps the grid defined
  const std::uint64_t budget = max_grid_entries_per_triangle * std::uint64_t{tested_triangles.triangles} + 1024;
  for (;; cell_size *= 2) {
    const uniform_grid grid(tested_triangles.domain, cell_size);
    if (grid.cell_count() > max_grid_cells) continue;
    chunk_entries = entries_per_chunk(boxes, defects, grid);
    if (saturating_sum(chunk_entries) <= budget) return grid;
  }
}

/// Digits of the radix sort of grid entries.
constexpr int radix_bits = 11;
constexpr std::size_t radix_buckets = std::size_t{1} << radix_bits;
constexpr std::size_t radix_chunk_size = std::size_t{1} << 16;

/// Stable parallel LSD radix sort of the entries by cell (the triangle bits are already in order). Each pass counts
/// digits per chunk, turns the counts into per-chunk write positions (digit-major, chunk order), then scatters.
void sort_by_cell(std::vector<grid_entry>& entries, int key_bits) {
  std::vector<grid_entry> scratch(entries.size());
  const std::size_t chunks = chunk_count(entries.size(), radix_chunk_size);
  std::vector<std::array<std::size_t, radix_buckets>> positions(chunks);
  for (int shift = 32; shift < 32 + key_bits; shift += radix_bits) {
    const auto digit = [shift](grid_entry entry) { return (entry >> shift) & (radix_buckets - 1); };
    for_each_chunk(
        entries.size(),
        [&](std::size_t chunk, std::size_t begin, std::size_t end) {
          positions[chunk].fill(0);
          for (std::size_t i = begin; i < end; ++i) ++positions[chunk][digit(entries[i])];
        },
        radix_chunk_size);
    std::size_t next = 0;
    for (std::size_t bucket = 0; bucket < radix_buckets; ++bucket) {
      for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
        const std::size_t count = positions[chunk][bucket];
        positions[chunk][bucket] = next;
        next += count;
      }
    }
    for_each_chunk(
        entries.size(),
        [&](std::size_t chunk, std::size_t begin, std::size_t end) {
          for (std::size_t i = begin; i < end; ++i) scratch[positions[chunk][digit(entries[i])]++] = entries[i];
        },
        radix_chunk_size);
    entries.swap(scratch);
  }
}

/// Every (cell, triangle) entry, sorted by cell then triangle.
std::vector<grid_entry> fill_grid(const std::vector<bounds>& boxes, const std::vector<triangle_defect>& defects,
                                  const uniform_grid& grid, const std::vector<std::uint64_t>& chunk_entries) {
  std::vector<std::size_t> chunk_offsets(chunk_entries.size() + 1, 0);
  for (std::size_t chunk = 0; chunk < chunk_entries.size(); ++chunk) {
    chunk_offsets[chunk + 1] = chunk_offsets[chunk] + static_cast<std::size_t>(chunk_entries[chunk]);
  }
  std::vector<grid_entry> entries(chunk_offsets.back());
  for_each_chunk(boxes.size(), [&](std::size_t chunk, std::size_t begin, std::size_t end) {
    std::size_t next = chunk_offsets[chunk];
    for (std::size_t t = begin; t < end; ++t) {
      if (!tested(defects, t)) continue;
      const cell_coordinates first = grid.first_cell(boxes[t]), last = grid.last_cell(boxes[t]);
      for (std::uint32_t x = first[0]; x <= last[0]; ++x) {
        for (std::uint32_t y = first[1]; y <= last[1]; ++y) {
          for (std::uint32_t z = first[2]; z <= last[2]; ++z) {
            entries[next++] = (grid_entry{grid.key(x, y, z)} << 32) | t;
          }
        }
      }
    }
  });
  sort_by_cell(entries, grid.key_bits());
  return entries;
}

/// Start of each run of entries sharing a cell, plus the end.
std::vector<std::size_t> cell_starts(const std::vector<grid_entry>& entries) {
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (i == 0 || cell_of(entries[i]) != cell_of(entries[i - 1])) starts.push_back(i);
  }
  starts.push_back(entries.size());
  return starts;
}

struct candidate {
  bounds box;
  std::array<std::uint32_t, 3> vertices;  ///< copied here: most overlapping pairs are neighbours, rejected by index
  std::uint32_t triangle;
  /// Bit a is set when the box starts in this cell along axis a. Both boxes of a pair in this cell start in it or
  /// before it, so their common box starts here (max of the starts, by monotonicity) exactly when, on every axis,
  /// at least one of them starts here: (a.starts_here | b.starts_here) == all_axes.
  std::uint8_t starts_here;
};

constexpr std::uint8_t all_axes = 0b111;

bool share_a_vertex(const std::array<std::uint32_t, 3>& t, const std::array<std::uint32_t, 3>& u) {
  for (const std::uint32_t a : t) {
    if (a == u[0] || a == u[1] || a == u[2]) return true;
  }
  return false;
}

/// Cells with more triangles than this are swept along x instead of testing every pair of boxes.
constexpr std::size_t sweep_threshold = 32;

/// Counts the intersecting pairs cell by cell; with `groups` it skips the pairs known apart, with `found` it also
/// lists the pairs it counts.
class cell_pair_counter {
 public:
  cell_pair_counter(const surface_mesh& mesh, const std::vector<bounds>& boxes, const uniform_grid& grid,
                    const std::vector<std::uint8_t>* groups = nullptr, std::vector<triangle_pair>* found = nullptr)
      : mesh_(mesh), boxes_(boxes), grid_(grid), groups_(groups), found_(found) {}

  /// Intersecting pairs tested in the cell of entries[begin, end).
  std::size_t count(const std::vector<grid_entry>& entries, std::size_t begin, std::size_t end) {
    const cell_coordinates cell = grid_.coordinates(cell_of(entries[begin]));
    candidates_.clear();
    for (std::size_t i = begin; i < end; ++i) {
      const std::uint32_t t = triangle_of(entries[i]);
      const cell_coordinates first = grid_.first_cell(boxes_[t]);
      std::uint8_t starts_here = 0;
      for (int axis = 0; axis < 3; ++axis) {
        starts_here |= static_cast<std::uint8_t>((first[axis] == cell[axis]) << axis);
      }
      candidates_.push_back({boxes_[t], mesh_.triangles[t], t, starts_here});
    }
    return candidates_.size() > sweep_threshold ? count_by_sweep() : count_all_pairs();
  }

 private:
  /// Whether the pair is examined here: the boxes overlap and their common box starts in this cell (so that the
  /// pair is examined once). Branch-free: the outcome is too random for a branch predictor.
  static bool examined_here(const candidate& a, const candidate& b) {
    return static_cast<int>((a.starts_here | b.starts_here) == all_axes) & static_cast<int>(a.box.overlaps(b.box));
  }

  /// Pairs sharing a vertex are left to the fan pass (analysis_fan_pairs.hpp).
  std::size_t count_if_intersecting(const candidate& a, const candidate& b) const {
    if (share_a_vertex(a.vertices, b.vertices)) return 0;
    if (groups_ != nullptr && known_apart_groups{*groups_}(a.triangle, b.triangle)) return 0;
    const auto corners = [this](const std::array<std::uint32_t, 3>& t) {
      return triangle_corners{mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]]};
    };
    if (!triangles_intersect(corners(a.vertices), corners(b.vertices))) return 0;
    if (found_ != nullptr) found_->push_back({std::min(a.triangle, b.triangle), std::max(a.triangle, b.triangle)});
    return 1;
  }

  /// For each candidate, the later ones examined with it are first collected as bits of a word without branching,
  /// then visited (cells have at most sweep_threshold ≤ 64 candidates here).
  std::size_t count_all_pairs() const {
    static_assert(sweep_threshold <= 64);
    std::size_t count = 0;
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
      std::uint64_t examined = 0;
      for (std::size_t j = i + 1; j < candidates_.size(); ++j) {
        examined |= static_cast<std::uint64_t>(examined_here(candidates_[i], candidates_[j])) << j;
      }
      for (; examined != 0; examined &= examined - 1) {
        count += count_if_intersecting(candidates_[i], candidates_[std::countr_zero(examined)]);
      }
    }
    return count;
  }

  /// Sorted by lo.x, the boxes overlapping a box in x are the ones that start before it ends.
  std::size_t count_by_sweep() {
    std::sort(candidates_.begin(), candidates_.end(), [](const candidate& a, const candidate& b) {
      return a.box.lo[0] < b.box.lo[0] || (a.box.lo[0] == b.box.lo[0] && a.triangle < b.triangle);
    });
    std::size_t count = 0;
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
      for (std::size_t j = i + 1; j < candidates_.size() && candidates_[j].box.lo[0] <= candidates_[i].box.hi[0]; ++j) {
        if (examined_here(candidates_[i], candidates_[j]))
          count += count_if_intersecting(candidates_[i], candidates_[j]);
      }
    }
    return count;
  }

  const surface_mesh& mesh_;
  const std::vector<bounds>& boxes_;
  const uniform_grid& grid_;
  const std::vector<std::uint8_t>* groups_;
  std::vector<triangle_pair>* found_;
  std::vector<candidate> candidates_;
};

/// The sorted grid of the tested triangles' boxes, ready for a cell_pair_counter.
struct separate_pairs_grid {
  std::vector<bounds> boxes;
  uniform_grid grid;
  std::vector<grid_entry> entries;
  std::vector<std::size_t> starts;  ///< see cell_starts
};

/// Empty (no cells) when fewer than two triangles are tested.
separate_pairs_grid make_separate_pairs_grid(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  std::vector<bounds> boxes = all_triangle_bounds(mesh, defects);
  const tested_set tested_triangles = survey(boxes, defects);
  if (tested_triangles.triangles < 2) {
    bounds point;
    point.include(vec3{});
    return {std::move(boxes), uniform_grid(point, 1), {}, {0}};
  }
  std::vector<std::uint64_t> chunk_entries;
  const uniform_grid grid = choose_grid(boxes, defects, tested_triangles, chunk_entries);
  std::vector<grid_entry> entries = fill_grid(boxes, defects, grid, chunk_entries);
  std::vector<std::size_t> starts = cell_starts(entries);
  return {std::move(boxes), grid, std::move(entries), std::move(starts)};
}

}  // namespace

std::size_t count_intersecting_separate_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  const separate_pairs_grid g = make_separate_pairs_grid(mesh, defects);
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, g.starts.size() - 1, 64), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& cells, std::size_t count) {
        cell_pair_counter counter(mesh, g.boxes, g.grid);
        for (std::size_t cell = cells.begin(); cell != cells.end(); ++cell) {
          count += counter.count(g.entries, g.starts[cell], g.starts[cell + 1]);
        }
        return count;
      },
      std::plus<>());
}

std::vector<triangle_pair> find_intersecting_separate_pairs(const surface_mesh& mesh,
                                                            const std::vector<triangle_defect>& defects,
                                                            const std::vector<std::uint8_t>& groups) {
  const separate_pairs_grid g = make_separate_pairs_grid(mesh, defects);
  return deterministic_reduce(
      g.starts.size() - 1, std::vector<triangle_pair>{},
      [&](std::size_t begin, std::size_t end) {
        std::vector<triangle_pair> found;
        cell_pair_counter counter(mesh, g.boxes, g.grid, &groups, &found);
        for (std::size_t cell = begin; cell < end; ++cell) counter.count(g.entries, g.starts[cell], g.starts[cell + 1]);
        return found;
      },
      append_pairs, pair_search_chunk);
}

}  // namespace tracemesh::detail
