#pragma once
/// @file atom_checks.hpp
/// Private helpers shared by the readers that build a molecule (xyzr, PDB, mmCIF): the limits every atom must
/// meet and the "nothing to mesh" check, with the same messages as the PQR reader. Not part of the public API.

#include <string>
#include <string_view>

#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh::detail {

/// Why `a` breaks the limits (a non-finite or too large coordinate, a negative — also -0.0 — non-finite or too
/// large radius), as a message fragment ("z coordinate 1e+09 is beyond +-1e+06 Angstrom
/// (limits.max_abs_coordinate)"); empty when it does not.
std::string atom_range_problem(const atom& a, const mesh_limits& limits);

/// Appends `a`, counting a zero radius in molecule::zero_radius_atoms.
void add_atom(molecule& mol, const atom& a);

/// errc::nothing_to_mesh ("no atoms with radius > 0: ...") when `mol` has no atom or only zero radii;
/// `records` names what an atom is in the format ("xyzr line", "ATOM or HETATM record").
status check_something_to_mesh(const molecule& mol, std::string_view records);

}  // namespace tracemesh::detail
