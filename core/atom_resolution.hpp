#pragma once
/// @file atom_resolution.hpp
/// Which atoms the mesher can resolve at a density (the rule: parameter_ranges::min_atom_surface_radius_per_edge).

#include "core/mesher.hpp"
#include "core/molecule.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// Edge length (Å) of an equilateral mesh with `density` vertices per Å²: the mesher's target edge length.
double mesh_edge_length(double density) noexcept;

/// Checks every atom with radius > 0 against the rule. An atom passes when its own surface sphere, radius
/// r·√(1 + ln t0 / d), is at least min_atom_surface_radius_per_edge mesh edges (O(atoms) when every atom does: the
/// usual case); or when its centre is buried in the surface of the atoms that pass so; or, on the surface of all
/// the atoms, when its centre lies outside it (it makes no feature of its own: with t0 ≥ e^{-d} no atom alone
/// reaches t0) or at least that radius inside it (sampled along 14 directions). Otherwise it is too small.
/// @param params    validated parameters (density, d, t0)
/// @param progress  polled while the molecule's surface is sampled around the atoms (errc::cancelled)
/// @return errc::unresolvable_input naming the first atom too small ("atom N" = the N-th atom record, 1-based), its
///         radius, how near the surface passes and the smallest radius resolved, and the density that resolves
///         every atom; ok otherwise.
status check_atom_resolution(const molecule& mol, const mesh_params& params,
                             const progress_token& progress = progress_token{});

}  // namespace tracemesh
