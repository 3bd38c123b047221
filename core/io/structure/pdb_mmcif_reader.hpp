#pragma once
/// @file pdb_mmcif_reader.hpp
/// Reads PDB and mmCIF text with gemmi (https://gemmi.readthedocs.io, Debian gemmi-dev) into atoms with radii
/// from a van der Waals table (vdw_radii.hpp). gemmi stays inside this target's .cpp: nothing here exposes it.
///
/// What is read:
/// - The first model only (NMR ensembles and MD files hold many).
/// - Element: PDB columns 77-78 when present, else gemmi's inference from the atom name; mmCIF
///   _atom_site.type_symbol. An atom without a known element, or whose element has no radius in the chosen
///   set, is an error naming the atom.
/// - Alternate locations: of the atoms of one residue with the same name and an altloc, the one with the
///   highest occupancy is kept, the first on a tie (per atom, as Biopython's DisorderedAtom selects).
/// - Hydrogens (H, D), waters (gemmi's water test: HOH, WAT, DOD, H2O, ...) and ligands (non-polymer, non-water
///   residues: ligands, ions, cofactors, glycans; gemmi's entity heuristics for PDB files without entities)
///   kept or dropped by structure_options.
/// - Atoms come in file order (grouped by gemmi's chains and residues); every atom has charge 0.
///
/// Checks (gemmi's PDB reader does not validate numbers, so the PDB text is checked line by line first):
/// - PDB: every ATOM/HETATM record (gemmi's rule: the first four characters, any case, are ATOM or HETA) up to
///   the first END record has at least 54 columns, decimal numbers in columns 31-38, 39-46 and 47-54 (x, y, z)
///   and, when not blank, in 55-60 (occupancy); errors name the line ("line 12: y coordinate 'abc' (columns
///   39-46) is not a decimal number").
/// - mmCIF: syntax errors name the line and column; the _atom_site loop must have type_symbol and Cartn_x/y/z,
///   and label_atom_id or auth_atom_id, label_comp_id or auth_comp_id (one error names every one missing). The
///   columns gemmi needs besides, but the mesh does not, are optional: id, label_alt_id (absent: no alternate
///   locations), label_asym_id (absent: auth_asym_id), occupancy (absent: 1), B_iso_or_equiv and auth_seq_id
///   (absent: label_seq_id). A coordinate that is not a number is an error naming the atom ("atom 12 (CA GLY A
///   5): ...").
/// - Both: the limits of mesh_limits (atoms counted over all atom records before any is dropped, coordinate
///   range, line length for PDB), and errc::nothing_to_mesh when no atom is left after the options.

#include <string_view>

#include "core/io/input_format.hpp"
#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// Parses PDB text. Errors: errc::invalid_input (messages above; gemmi's own errors, e.g. "Problem in line 7:
/// duplicate MODEL number", pass through), errc::limit_exceeded, errc::nothing_to_mesh.
result<molecule> parse_pdb(std::string_view text, const structure_options& options = {},
                           const mesh_limits& limits = {});

/// Parses mmCIF text (the first data block). Errors as parse_pdb.
result<molecule> parse_mmcif(std::string_view text, const structure_options& options = {},
                             const mesh_limits& limits = {});

}  // namespace tracemesh
