#pragma once
/// @file trace_lines.hpp
/// The lines of the trace path: every line parallel to x through lattice points (J·h̃, K·h̃) that holds a root of
/// φ = t0, with its roots sorted by x (line_roots.hpp proves them complete).

#include <cstdint>
#include <span>
#include <vector>

#include "core/vec3.hpp"

namespace tracemesh {

/// A line's place in the lattice: y = J·h̃, z = K·h̃.
struct line_id {
  std::int64_t j = 0, k = 0;
  friend constexpr bool operator==(const line_id&, const line_id&) = default;
  friend constexpr bool operator<(const line_id& a, const line_id& b) { return a.j < b.j || (a.j == b.j && a.k < b.k); }
};

/// A root on a line: its x and the gradient of φ there.
struct line_point {
  double x = 0;
  vec3 gradient;
};

/// Lines sorted by (J, K), roots of each sorted by x, stored flat.
class trace_lines {
 public:
  /// Builds from (line, root) pairs in any order; equal roots (within merge_tolerance) are kept once.
  struct entry {
    line_id line;
    line_point point;
  };
  explicit trace_lines(std::vector<entry> entries = {});

  std::size_t line_count() const { return ids_.size(); }
  std::size_t root_count() const { return points_.size(); }
  const line_id& id(std::size_t line) const { return ids_[line]; }
  /// Index of `line`, or line_count() when it holds no root.
  std::size_t find(const line_id& line) const;
  /// The roots of line `line` (an index), sorted by x.
  std::span<const line_point> roots(std::size_t line) const {
    return {points_.data() + first_[line], points_.data() + first_[line + 1]};
  }
  /// Roots of `line` (an id); empty when it holds none.
  std::span<const line_point> roots_of(const line_id& line) const;
  /// Global index of root `r` of line `line` (lines in order, roots in order): the vertex number of the root.
  std::uint32_t global_index(std::size_t line, std::size_t r) const {
    return static_cast<std::uint32_t>(first_[line] + r);
  }
  /// Index (within the line's roots) of the root nearest x within merge_tolerance, or -1.
  std::int64_t match(std::span<const line_point> roots, double x) const;

  /// All (line, root) pairs, for rebuilding.
  std::vector<entry> entries() const;

  /// Two roots of one line closer than this (Å) are the same root.
  static constexpr double merge_tolerance = 1e-6;

 private:
  std::vector<line_id> ids_;
  std::vector<std::size_t> first_;  ///< roots of line n are points_[first_[n], first_[n + 1])
  std::vector<line_point> points_;
};

}  // namespace tracemesh
