#pragma once
/// @file mesh.hpp
/// The triangle mesh the mesher produces: plain arrays (libigl/OpenVDB style).

#include <array>
#include <cstdint>
#include <vector>

#include "core/vec3.hpp"

namespace tracemesh {

struct surface_mesh {
  std::vector<vec3> positions;                     ///< Å, on the surface φ = t0
  std::vector<vec3> normals;                       ///< outward unit normals, −∇φ/|∇φ| at each vertex
  std::vector<std::uint32_t> atom_index;           ///< index (into molecule::atoms) of the atom contributing most to φ
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise seen from outside

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t triangle_count() const { return triangles.size(); }
};

}  // namespace tracemesh
