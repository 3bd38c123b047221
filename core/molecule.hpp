#pragma once
/// @file molecule.hpp
/// Atoms as read from a PQR file.

#include <cstddef>
#include <vector>

#include "core/vec3.hpp"

namespace tracemesh {

struct atom {
  vec3 center;         ///< Å
  double radius = 0;   ///< Å; 0 for atoms that do not contribute to φ (AMBER hydroxyl H)
  double charge = 0;   ///< e
};

struct molecule {
  std::vector<atom> atoms;          ///< in file order, including radius-0 atoms
  std::size_t zero_radius_atoms = 0;  ///< how many atoms have radius 0 (reported, not meshed)
};

}  // namespace tracemesh
