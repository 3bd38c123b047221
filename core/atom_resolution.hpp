#pragma once
/// @file atom_resolution.hpp
/// Which atoms the mesher can resolve at a density (the rule: parameter_ranges::min_atom_surface_radius_per_edge).

#include "core/mesher.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// Edge length (Å) of an equilateral mesh with `density` vertices per Å²: the mesher's target edge length.
double mesh_edge_length(double density) noexcept;

/// Checks every atom with radius > 0 against the rule: its own surface sphere, radius r·√(1 + ln t0 / d), at least
/// min_atom_surface_radius_per_edge mesh edges, unless its centre is buried in the surface of the atoms that pass
/// (then it makes no feature of its own). With t0 ≥ e^{-d} no atom has a sphere of its own and every atom passes.
/// O(atoms) when every atom is resolvable (the usual case); otherwise one field is built over the resolvable atoms to
/// tell buried atoms from exposed ones.
/// @param params  validated parameters (density, d, t0)
/// @return errc::unresolvable_input naming the first exposed unresolvable atom ("atom N" = the N-th atom record,
///         1-based), its radius, the smallest resolvable radius and the density that would resolve it; ok otherwise.
status check_atom_resolution(const molecule& mol, const mesh_params& params);

}  // namespace tracemesh
