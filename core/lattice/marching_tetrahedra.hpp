#pragma once
/// @file marching_tetrahedra.hpp
/// Polygons of {φ = t0} inside one block: each lattice cube is split into six tetrahedra around its main diagonal
/// (Freudenthal/Kuhn split, the same in every cube, so neighbouring cubes share face diagonals), and each tetrahedron
/// whose corners lie on both sides of t0 yields a triangle or a quadrilateral whose vertices are on its cut edges.
/// Polygons refer to vertices by lattice edge key, so blocks mesh independently and meet exactly.
/// Inside means φ ≥ t0. Polygons are oriented counter-clockwise seen from outside (from lower φ).

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/lattice/lattice.hpp"

namespace tracemesh {

struct block_polygons {
  std::vector<std::array<std::uint64_t, 3>> triangles;
  std::vector<std::array<std::uint64_t, 4>> quads;  ///< cyclic order; split later along the shorter diagonal
  void clear() {
    triangles.clear();
    quads.clear();
  }
};

/// Appends the polygons of the block_cells³ cubes of `block` to `out`. `values`: φ at the block's lattice points
/// as filled by sample_block.
void triangulate_block(const lattice& lat, const lattice_index& block, std::span<const double> values, double t0,
                       block_polygons& out);

}  // namespace tracemesh
