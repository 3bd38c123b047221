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
/// - Biological assemblies (structure_options::assembly other than deposited_assembly): gemmi reads the file's
///   assemblies (PDB REMARK 350 BIOMOLECULE / BIOMT, mmCIF _pdbx_struct_assembly, _pdbx_struct_assembly_gen and
///   _pdbx_struct_oper_list) and builds the one asked for from the first model (gemmi::make_assembly): each
///   generator's operators applied in turn to its chains (PDB) or label_asym_id subchains (mmCIF), every copy a
///   chain of its own (A → A1, A2, ...); an mmCIF product of operator groups "(X0)(1-60)" is composed here, right
///   to left as the mmCIF dictionary defines it (gemmi reads its first group only). The choices above (alternate
///   locations, waters, ligands, hydrogens) are made on the deposited model, so they are the same in every copy.
///   The atoms come generator by generator, operator by operator, then in file order. Copies of one atom that the operators place within 0.2 Å of each other (an ion on a
///   symmetry axis) are merged into one at their mean position, the first copy's place in the order
///   (gemmi::merge_atoms_in_expanded_model, as gemmi's own assembly tool does): the Gaussian density counts each
///   atom once.
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
/// - Assemblies: an id the file does not list is an error listing the ids it has (errc::invalid_input); the
///   records are checked first (assembly_records.hpp: BIOMT numbers, mmCIF operator expressions, every operator
///   id in _pdbx_struct_oper_list); an operator must be a rotation and a translation (its matrix orthonormal
///   within 0.01: a damaged matrix would distort the copies), and each generator must reach at least one atom
///   of the model. The assembly's atoms (every copy, before the options drop any) count against
///   mesh_limits::max_atoms before it is built (errc::limit_exceeded).

#include <cstddef>
#include <string_view>

#include "core/io/input_format.hpp"
#include "core/limits.hpp"
#include "core/molecule.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// What a PDB or mmCIF reader made: the atoms, and how many symmetry operators built them.
struct structure_read {
  molecule mol;
  std::size_t assembly_operators = 0;  ///< operators applied over all generators; 0 for deposited_assembly
  std::size_t assembly_merged_atoms = 0;  ///< copies merged into another copy of their atom (see above)
};

/// Reads PDB text as the options ask, the assembly included. Errors as parse_pdb.
result<structure_read> read_pdb_structure(std::string_view text, const structure_options& options = {},
                                          const mesh_limits& limits = {});

/// Reads mmCIF text (the first data block) as the options ask, the assembly included. Errors as parse_pdb.
result<structure_read> read_mmcif_structure(std::string_view text, const structure_options& options = {},
                                            const mesh_limits& limits = {});

/// Parses PDB text. Errors: errc::invalid_input (messages above; gemmi's own errors, e.g. "Problem in line 7:
/// duplicate MODEL number", pass through), errc::limit_exceeded, errc::nothing_to_mesh.
result<molecule> parse_pdb(std::string_view text, const structure_options& options = {},
                           const mesh_limits& limits = {});

/// Parses mmCIF text (the first data block). Errors as parse_pdb.
result<molecule> parse_mmcif(std::string_view text, const structure_options& options = {},
                             const mesh_limits& limits = {});

}  // namespace tracemesh
