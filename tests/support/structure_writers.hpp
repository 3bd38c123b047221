#pragma once
// The same atoms written as PDB, mmCIF, xyzr and PQR text, for the tests that check that every input format
// gives the same molecule (and the same job). There is no internet here, so the PDB and mmCIF versions of a real
// molecule are written from its PQR: names, residues and coordinates as in the PQR, the element from the first
// letter of the atom name (true of the CHARMM names of fas2 and gly), radii from a van der Waals table.
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/vdw_radii.hpp"

namespace tracemesh::testing {

struct named_atom {
  int serial = 0;
  std::string name, residue;
  int residue_number = 0;
  double x = 0, y = 0, z = 0;
  std::string element;
};

/// The atoms of a 10-field PQR text (ATOM serial name resName resSeq x y z q r), element from the name.
inline std::vector<named_atom> atoms_of_pqr(const std::string& pqr) {
  std::vector<named_atom> atoms;
  std::istringstream lines(pqr);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream fields(line);
    std::string record;
    named_atom a;
    double charge = 0, radius = 0;
    if (!(fields >> record) || (record != "ATOM" && record != "HETATM")) continue;
    fields >> a.serial >> a.name >> a.residue >> a.residue_number >> a.x >> a.y >> a.z >> charge >> radius;
    a.element = a.name.substr(0, 1);
    atoms.push_back(a);
  }
  return atoms;
}

inline std::string formatted(const char* format, auto... values) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, format, values...);
  return buffer;
}

/// PDB fixed columns (names of under four characters start in column 14), chain A, elements in 77-78.
inline std::string to_pdb(const std::vector<named_atom>& atoms) {
  std::string out = "HEADER    TEST STRUCTURE WRITTEN FROM A PQR\n";
  for (const named_atom& a : atoms) {
    const std::string name = a.name.size() < 4 ? " " + a.name : a.name;
    out += formatted("ATOM  %5d %-4s %3s A%4d    %8.3f%8.3f%8.3f%6.2f%6.2f          %2s\n", a.serial, name.c_str(),
                     a.residue.c_str(), a.residue_number, a.x, a.y, a.z, 1.0, 20.0, a.element.c_str());
  }
  return out + "END\n";
}

/// mmCIF with the _atom_site columns gemmi reads.
inline std::string to_mmcif(const std::vector<named_atom>& atoms) {
  std::string out =
      "data_test\n#\nloop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
      "_atom_site.label_alt_id\n_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.label_entity_id\n"
      "_atom_site.label_seq_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.occupancy\n"
      "_atom_site.B_iso_or_equiv\n_atom_site.auth_seq_id\n_atom_site.auth_asym_id\n_atom_site.pdbx_PDB_model_num\n";
  for (const named_atom& a : atoms) {
    out += formatted("ATOM %d %s %s . %s A 1 %d %.3f %.3f %.3f 1.00 20.00 %d A 1\n", a.serial, a.element.c_str(),
                     a.name.c_str(), a.residue.c_str(), a.residue_number, a.x, a.y, a.z, a.residue_number);
  }
  return out + "#\n";
}

/// x y z r, radii from `set`.
inline std::string to_xyzr(const std::vector<named_atom>& atoms, radii_set set) {
  std::string out;
  for (const named_atom& a : atoms) {
    out += formatted("%.3f %.3f %.3f %.2f\n", a.x, a.y, a.z, vdw_radius(set, a.element).value_or(-1));
  }
  return out;
}

/// 10-field PQR, charge 0 and radii from `set`.
inline std::string to_pqr(const std::vector<named_atom>& atoms, radii_set set) {
  std::string out;
  for (const named_atom& a : atoms) {
    out += formatted("ATOM %d %s %s %d %.3f %.3f %.3f 0.0 %.2f\n", a.serial, a.name.c_str(), a.residue.c_str(),
                     a.residue_number, a.x, a.y, a.z, vdw_radius(set, a.element).value_or(-1));
  }
  return out;
}

}  // namespace tracemesh::testing
