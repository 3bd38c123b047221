#pragma once
/// @file lattice.hpp
/// The sampling lattice: points (I·h, J·h, K·h) for integer I, J, K, anchored at the origin so that a point's
/// coordinates never depend on the molecule. Space is tiled by blocks of block_cells³ lattice cells; culling keeps
/// blocks, sampling fills them, marching tetrahedra meshes them. Lattice edges are keyed by their lower end point and
/// one of seven directions (the edges of the Freudenthal split of each cube).

#include <array>
#include <cstdint>

#include "core/field/gaussian_field.hpp"
#include "core/limits.hpp"
#include "core/status.hpp"
#include "core/vec3.hpp"

namespace tracemesh {

struct lattice_index {
  std::int64_t i = 0, j = 0, k = 0;
  friend constexpr bool operator==(const lattice_index&, const lattice_index&) = default;
};

/// The seven edge directions of the Freudenthal split (all components 0 or 1).
inline constexpr std::array<std::array<int, 3>, 7> edge_directions{{
    {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1},
}};
/// Direction index of (dx, dy, dz) ∈ {0,1}³ \ {0}; -1 for the zero vector.
constexpr int edge_direction_index(int dx, int dy, int dz) {
  for (int n = 0; n < 7; ++n) {
    if (edge_directions[n][0] == dx && edge_directions[n][1] == dy && edge_directions[n][2] == dz) return n;
  }
  return -1;
}

class lattice {
 public:
  static constexpr int block_cells = 8;  ///< lattice cells per block edge

  /// spacing h (Å); `origin_index` is the lowest lattice index in use (keys are packed relative to it).
  lattice(double spacing, lattice_index origin_index) : h_(spacing), origin_(origin_index) {}

  double spacing() const { return h_; }
  const lattice_index& origin_index() const { return origin_; }
  vec3 point(const lattice_index& p) const {
    return {static_cast<double>(p.i) * h_, static_cast<double>(p.j) * h_, static_cast<double>(p.k) * h_};
  }
  /// Block (bi, bj, bk) covers lattice indices [b·block_cells, (b+1)·block_cells] on each axis.
  box3 block_box(const lattice_index& block) const {
    const double s = h_ * block_cells;
    return {{block.i * s, block.j * s, block.k * s}, {(block.i + 1) * s, (block.j + 1) * s, (block.k + 1) * s}};
  }

  /// Packs an edge (lower end point, direction 0..6) into 64 bits: 20 bits per axis relative to the origin.
  /// Precondition: 0 ≤ p − origin < 2²⁰ on every axis (the mesher checks the extent against mesh_limits).
  std::uint64_t edge_key(const lattice_index& p, int direction) const {
    const auto rel = [](std::int64_t v, std::int64_t o) { return static_cast<std::uint64_t>(v - o); };
    return (rel(p.i, origin_.i) << 43) | (rel(p.j, origin_.j) << 23) | (rel(p.k, origin_.k) << 3) |
           static_cast<std::uint64_t>(direction);
  }
  /// The fields never carry into each other, so keys are linear: edge_key(p + (di, dj, dk), direction) ==
  /// edge_key(p, 0) + edge_key_offset(di, dj, dk, direction) for non-negative offsets within the precondition.
  static constexpr std::uint64_t edge_key_offset(int di, int dj, int dk, int direction) {
    return (static_cast<std::uint64_t>(di) << 43) + (static_cast<std::uint64_t>(dj) << 23) +
           (static_cast<std::uint64_t>(dk) << 3) + static_cast<std::uint64_t>(direction);
  }
  /// Inverse of edge_key: the edge's two end points.
  std::array<lattice_index, 2> edge_ends(std::uint64_t key) const {
    constexpr std::uint64_t mask = (1ULL << 20) - 1;
    const lattice_index a{static_cast<std::int64_t>((key >> 43) & mask) + origin_.i,
                          static_cast<std::int64_t>((key >> 23) & mask) + origin_.j,
                          static_cast<std::int64_t>((key >> 3) & mask) + origin_.k};
    const auto& dir = edge_directions[key & 7];
    return {a, lattice_index{a.i + dir[0], a.j + dir[1], a.k + dir[2]}};
  }

 private:
  double h_;
  lattice_index origin_;
};

/// The lattice of spacing `spacing` (Å) covering every atom's cutoff sphere with a margin of two blocks, or
/// errc::limit_exceeded when it needs more than limits.max_lattice_extent points per axis. Both paths cull its
/// blocks (band_culling.hpp); the lattice path samples them, the trace path puts its lines on its points.
result<lattice> make_lattice(const gaussian_field& field, double spacing, const mesh_limits& limits);

}  // namespace tracemesh
