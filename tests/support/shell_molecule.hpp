#pragma once
// A synthetic molecule with a cavity: a hollow shell of atoms with one atom at its centre. Its Gaussian surface
// has three components at density 1–2: the outer surface, the inner cavity (enclosed, negative volume) and the
// island around the central atom (enclosed, positive volume).
#include <cmath>
#include <numbers>

#include "core/molecule.hpp"

namespace tracemesh::testing {

/// `count` atoms of radius r on a Fibonacci sphere of radius R around `centre`: a closed shell around a void when
/// the atoms overlap; without those whose z offset from the centre exceeds `z_cap` (an opening at the top when
/// z_cap < R).
inline molecule fibonacci_shell(int count, double R, double r, const vec3& centre = {}, double z_cap = 1e9) {
  molecule mol;
  const double golden = std::numbers::pi * (3 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1 - 2 * (i + 0.5) / count;
    const double rho = std::sqrt(1 - z * z);
    const double angle = golden * i;
    if (R * z > z_cap) continue;
    mol.atoms.push_back({centre + vec3{R * rho * std::cos(angle), R * rho * std::sin(angle), R * z}, r, 0});
  }
  return mol;
}

/// `count` atoms of radius 1.8 Å on a Fibonacci sphere of radius 8 Å (a closed shell about 3.6 Å thick), plus one
/// atom of radius 1.8 Å at the centre, about 4 Å from the shell's inner surface.
inline molecule shell_with_island(int count = 250) {
  molecule mol = fibonacci_shell(count, 8, 1.8);
  mol.atoms.push_back({vec3{0, 0, 0}, 1.8, 0});
  return mol;
}

}  // namespace tracemesh::testing
