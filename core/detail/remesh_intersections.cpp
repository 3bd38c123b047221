#include "core/detail/remesh_intersections.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>

#include "core/detail/remesh_geometry.hpp"

namespace tracemesh::detail {
namespace {

/// Is x (near the plane of the triangle, unit normal u) inside the triangle or within `tolerance` of it?
bool point_in_triangle(const vec3& x, const vec3& a, const vec3& b, const vec3& c, const vec3& u,
                       double tolerance) {
  const std::array<vec3, 3> corners{a, b, c};
  for (int i = 0; i < 3; ++i) {
    const vec3& s = corners[i];
    const vec3& e = corners[(i + 1) % 3];
    const double length = distance(s, e);
    // In-plane signed distance of x from the edge line, positive towards the inside.
    if (dot(cross(e - s, x - s), u) < -tolerance * length) return false;
  }
  return true;
}

/// Smallest distance between segments p1–q1 and p2–q2 (closest points by clamped parameters).
double segment_distance(const vec3& p1, const vec3& q1, const vec3& p2, const vec3& q2) {
  const vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  double s = 0, t = 0;
  if (a <= 0 && e <= 0) return distance(p1, p2);
  if (a <= 0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = dot(d1, r);
    if (e <= 0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = dot(d1, d2), denominator = a * e - b * b;
      s = denominator > 0 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return distance(p1 + d1 * s, p2 + d2 * t);
}

/// Strictly on one side of the plane of `t` (beyond the tolerance)?
bool all_beyond_plane(const std::array<vec3, 3>& t, const std::array<vec3, 3>& points, double tolerance) {
  const vec3 u = normalized(area_vector(t[0], t[1], t[2]));
  int above = 0, below = 0;
  for (const vec3& p : points) {
    const double side = dot(u, p - t[0]);
    above += side > tolerance;
    below += side < -tolerance;
  }
  return above == 3 || below == 3;
}

int shared_vertex_count(const std::array<std::uint32_t, 3>& s, const std::array<std::uint32_t, 3>& t) {
  int count = 0;
  for (const std::uint32_t a : s) count += (a == t[0]) + (a == t[1]) + (a == t[2]);
  return count;
}

/// The pair test the certificate applies to triangles i and j of the mesh.
bool pair_intersects(const std::vector<vec3>& positions, const std::array<std::uint32_t, 3>& s,
                     const std::array<std::uint32_t, 3>& t, double tolerance) {
  const int shared = shared_vertex_count(s, t);
  if (shared >= 2) return false;
  const auto corners = [&](const std::array<std::uint32_t, 3>& f) {
    return std::array<vec3, 3>{positions[f[0]], positions[f[1]], positions[f[2]]};
  };
  if (shared == 0) return triangles_intersect(corners(s), corners(t), tolerance);
  // Rotate both so the shared vertex comes first.
  int i = 0, j = 0;
  while (s[i] != t[0] && s[i] != t[1] && s[i] != t[2]) ++i;
  while (t[j] != s[i]) ++j;
  return triangles_meet_beyond_vertex(positions[s[i]], positions[s[(i + 1) % 3]], positions[s[(i + 2) % 3]],
                                      positions[t[(j + 1) % 3]], positions[t[(j + 2) % 3]], tolerance);
}

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

bool boxes_overlap(const box& a, const box& b, double tolerance) {
  for (int axis = 0; axis < 3; ++axis) {
    if (a.lo[axis] > b.hi[axis] + tolerance || b.lo[axis] > a.hi[axis] + tolerance) return false;
  }
  return true;
}

/// Uniform grid over triangle bounding-box centres. The cell is at least as large as every box, so two boxes that
/// overlap have their centres in the same or in adjacent cells.
class triangle_grid {
 public:
  static constexpr int key_bits = 21;

  triangle_grid(const std::vector<box>& boxes, double tolerance) {
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
    cell_ = std::max({largest + 2 * tolerance, extent / max_cells, 1e-6});
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

bool segment_meets_triangle(const vec3& p, const vec3& q, const vec3& a, const vec3& b, const vec3& c,
                            double tolerance) {
  const vec3 n = area_vector(a, b, c);
  const double length = norm(n);
  if (!(length > 0)) return true;
  const vec3 u = n / length;
  const double dp = dot(u, p - a), dq = dot(u, q - a);
  if ((dp > tolerance && dq > tolerance) || (dp < -tolerance && dq < -tolerance)) return false;
  if (std::abs(dp) <= tolerance && std::abs(dq) <= tolerance) {
    // In the plane: an end point inside, or the segment reaching an edge.
    return point_in_triangle(p, a, b, c, u, tolerance) || point_in_triangle(q, a, b, c, u, tolerance) ||
           segment_distance(p, q, a, b) <= tolerance || segment_distance(p, q, b, c) <= tolerance ||
           segment_distance(p, q, c, a) <= tolerance;
  }
  const double t = std::clamp(dp / (dp - dq), 0.0, 1.0);
  return point_in_triangle(p + (q - p) * t, a, b, c, u, tolerance);
}

bool triangles_intersect(const std::array<vec3, 3>& a, const std::array<vec3, 3>& b, double tolerance) {
  if (all_beyond_plane(a, b, tolerance) || all_beyond_plane(b, a, tolerance)) return false;
  // Two triangles meet exactly when an edge of one meets the other (the intersection's end points lie on edges).
  for (int i = 0; i < 3; ++i) {
    if (segment_meets_triangle(a[i], a[(i + 1) % 3], b[0], b[1], b[2], tolerance)) return true;
    if (segment_meets_triangle(b[i], b[(i + 1) % 3], a[0], a[1], a[2], tolerance)) return true;
  }
  return false;
}

bool triangles_meet_beyond_vertex(const vec3& v, const vec3& a1, const vec3& a2, const vec3& b1, const vec3& b2,
                                  double tolerance) {
  return segment_meets_triangle(a1, a2, v, b1, b2, tolerance) || segment_meets_triangle(b1, b2, v, a1, a2, tolerance);
}

std::vector<triangle_pair> find_intersecting_pairs(const std::vector<vec3>& positions, const triangle_list& triangles,
                                                   double tolerance) {
  if (triangles.size() < 2) return {};
  std::vector<box> boxes(triangles.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size()), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) boxes[t] = triangle_box(positions, triangles[t]);
  });
  const triangle_grid grid(boxes, tolerance);
  const auto& cells = grid.cells();
  const auto& entries = grid.entries();

  tbb::enumerable_thread_specific<std::vector<triangle_pair>> found;
  tbb::enumerable_thread_specific<std::vector<const triangle_grid::cell*>> neighbour_lists;
  const auto test = [&](std::uint32_t s, std::uint32_t t, std::vector<triangle_pair>& out) {
    if (!boxes_overlap(boxes[s], boxes[t], tolerance)) return;
    if (pair_intersects(positions, triangles[s], triangles[t], tolerance)) out.push_back({std::min(s, t), std::max(s, t)});
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

}  // namespace tracemesh::detail
