#include "core/io/structure/pdb_mmcif_reader.hpp"

#include <gemmi/assembly.hpp>
#include <gemmi/cif.hpp>
#include <gemmi/mmcif.hpp>
#include <gemmi/pdb.hpp>
#include <gemmi/polyheur.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/io/atom_checks.hpp"
#include "core/io/pqr_text.hpp"
#include "core/io/structure/assembly_records.hpp"
#include "core/io/text_lines.hpp"

namespace tracemesh {

namespace {

using detail::has_record_prefix;
using detail::trimmed;

/// gemmi's messages can quote whole lines: at most this many characters of one, once escaped, go into ours.
constexpr std::size_t max_gemmi_message_chars = 160;
/// PDB columns (1-based, inclusive) of x, y, z and occupancy.
struct pdb_column {
  const char* name;
  std::size_t first, last;
};
constexpr pdb_column pdb_coordinates[] = {
    {"x coordinate", 31, 38}, {"y coordinate", 39, 46}, {"z coordinate", 47, 54}};
constexpr pdb_column pdb_occupancy = {"occupancy", 55, 60};

bool is_pdb_atom_record(std::string_view line) {
  return has_record_prefix(line, "ATOM") || has_record_prefix(line, "HETA");
}
/// gemmi stops at "END" followed by a blank or the end of the line (not ENDMDL).
bool is_pdb_end_record(std::string_view line) {
  return has_record_prefix(line, "END") && (line.size() == 3 || line[3] == ' ' || line[3] == '\t');
}

/// Columns that gemmi reads of every line as a record name, by shifting its (signed) chars: 1-4 for the record,
/// 5-7 for its mmJSON sniff. They must be ASCII (a PDB record name always is); a fuzz find.
constexpr std::size_t pdb_record_name_columns = 7;
bool has_ascii_record_name(std::string_view line) {
  const std::string_view name = line.substr(0, pdb_record_name_columns);
  return std::none_of(name.begin(), name.end(), [](char c) { return static_cast<unsigned char>(c) >= 0x80; });
}

/// Whether gemmi's string_to_int (blanks, a sign, then digits, into an int without an overflow check) would
/// overflow on `value`: a signed overflow, undefined behaviour (fuzz finds: UBSan on an mmCIF _atom_site.auth_seq_id
/// of 11 digits, and on the 10-column sequence numbers of a PDB DBREF2 record). Leading zeros do not count.
bool overflows_gemmi_int(std::string_view value) {
  std::size_t i = 0;
  while (i < value.size() && (value[i] == ' ' || (value[i] >= '\t' && value[i] <= '\r'))) ++i;
  bool negative = false;
  if (i < value.size() && (value[i] == '-' || value[i] == '+')) negative = value[i++] == '-';
  constexpr long long int_magnitude = 2147483648LL;  // -INT_MIN: gemmi sums negatively, then negates
  long long magnitude = 0;
  for (; i < value.size() && value[i] >= '0' && value[i] <= '9'; ++i) {
    magnitude = magnitude * 10 + (value[i] - '0');
    if (magnitude > int_magnitude) return true;
  }
  return !negative && magnitude == int_magnitude;
}

/// gemmi reads the database sequence numbers of a DBREF2 record (the first four characters DBRE in any case, the
/// sixth '2') from columns 46-55 and 58-67 as ints, past the end of a shorter line (into its line buffer's earlier
/// contents): such records are padded to this many columns, and numbers beyond the int range refused.
constexpr std::size_t pdb_dbref2_columns = 67;
constexpr pdb_column pdb_dbref2_numbers[] = {{"database sequence begin", 46, 55}, {"database sequence end", 58, 67}};
bool is_dbref2_record(std::string_view line) {
  return has_record_prefix(line, "DBRE") && line.size() > 5 && line[5] == '2';
}

/// The checks gemmi's PDB reader leaves out, line by line, with the line named.
status check_pdb_text(std::string_view text, const mesh_limits& limits) {
  detail::text_lines lines(text, limits.max_line_bytes, "PDB");
  std::size_t atom_records = 0;
  std::string_view line;
  for (;;) {
    result<bool> more = lines.next(line);
    if (!more) return more.error();
    if (!*more || is_pdb_end_record(line)) return status::success();
    if (!has_ascii_record_name(line)) {
      return detail::line_error(lines.line_number(), "record name '" + detail::quote_bytes(line.substr(0, 6)) +
                                                         "' (columns 1-6) is not ASCII; PDB text is ASCII");
    }
    if (is_dbref2_record(line)) {
      for (const pdb_column& column : pdb_dbref2_numbers) {
        const std::size_t first = std::min(line.size(), column.first - 1);
        const std::string_view field = line.substr(first, column.last - column.first + 1);
        if (overflows_gemmi_int(field)) {
          return detail::line_error(lines.line_number(), std::string(column.name) + " '" +
                                                             detail::quote_bytes(field) + "' (columns " +
                                                             std::to_string(column.first) + "-" +
                                                             std::to_string(column.last) +
                                                             ") is an integer beyond the 32-bit range");
        }
      }
    }
    if (!is_pdb_atom_record(line)) continue;
    const std::size_t number = lines.line_number();
    if (++atom_records > limits.max_atoms) {
      return {errc::limit_exceeded, "line " + std::to_string(number) + ": more than " +
                                        std::to_string(limits.max_atoms) + " atoms (limits.max_atoms)"};
    }
    if (line.size() < pdb_coordinates[2].last) {
      return detail::line_error(number, "atom record of " + std::to_string(line.size()) +
                                            " columns; a PDB atom record has x y z in columns 31-54");
    }
    for (const pdb_column& column : pdb_coordinates) {
      const std::string_view field = trimmed(line.substr(column.first - 1, column.last - column.first + 1));
      const detail::parsed_number parsed = detail::parse_number(field);
      if (parsed.error != detail::number_error::none) {
        return detail::line_error(number, std::string(column.name) + " '" + detail::quote_bytes(field) +
                                              "' (columns " + std::to_string(column.first) + "-" +
                                              std::to_string(column.last) + ") is not a decimal number");
      }
      if (std::fabs(parsed.value) > limits.max_abs_coordinate) {
        return detail::line_error(number, std::string(column.name) + " " + detail::quote_bytes(field) +
                                              " is beyond +-" + detail::format_number(limits.max_abs_coordinate) +
                                              " Angstrom (limits.max_abs_coordinate)");
      }
    }
    const std::string_view occupancy =
        line.size() < pdb_occupancy.first ? std::string_view() : trimmed(line.substr(pdb_occupancy.first - 1, 6));
    if (!occupancy.empty() && detail::parse_number(occupancy).error != detail::number_error::none) {
      return detail::line_error(number, "occupancy '" + detail::quote_bytes(occupancy) +
                                            "' (columns 55-60) is not a decimal number");
    }
  }
}

/// gemmi splits lines at LF only; the text readers also accept CR and CRLF.
std::string with_lf_line_ends(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\r') {
      out += text[i];
    } else if (i + 1 >= text.size() || text[i + 1] != '\n') {
      out += '\n';
    }
  }
  return out;
}

/// gemmi reads columns 73-80 of a LINK or SSBOND record longer than 73 bytes without checking its length (a heap
/// read past the line, a fuzz find). gemmi's record keeps its line feed, so a line of 73 columns is such a record
/// too (a second fuzz find): records of 73 to 79 columns are padded with blanks to this many columns.
constexpr std::size_t pdb_connection_record_columns = 80;
/// The columns `line` is padded to for gemmi (see above and pdb_dbref2_columns), or its own size.
std::size_t columns_for_gemmi(std::string_view line) {
  if ((has_record_prefix(line, "LINK") || has_record_prefix(line, "SSBO")) && line.size() >= 73) {
    return std::max(line.size(), pdb_connection_record_columns);
  }
  if (is_dbref2_record(line)) return std::max(line.size(), pdb_dbref2_columns);
  return line.size();
}

/// The text as gemmi's PDB reader needs it: LF line ends, short connection and DBREF2 records padded. Empty when
/// `text` already is.
std::string text_for_gemmi(std::string_view text) {
  const std::string lf_text = text.find('\r') == std::string_view::npos ? std::string() : with_lf_line_ends(text);
  const std::string_view input = lf_text.empty() ? text : std::string_view(lf_text);
  std::string padded;
  std::size_t copied = 0;  // bytes of input already in `padded`
  for (std::size_t begin = 0; begin < input.size();) {
    const std::size_t end = std::min(input.find('\n', begin), input.size());
    if (const std::size_t columns = columns_for_gemmi(input.substr(begin, end - begin)); columns > end - begin) {
      padded.append(input.substr(copied, end - copied));
      padded.append(columns - (end - begin), ' ');
      copied = end;
    }
    begin = end + 1;
  }
  if (copied == 0) return lf_text;
  padded.append(input.substr(copied));
  return padded;
}

std::string atom_label(const gemmi::Chain& chain, const gemmi::Residue& residue, const gemmi::Atom& a) {
  return "atom " + std::to_string(a.serial) + " (" + detail::quote_bytes(a.name) + " " +
         detail::quote_bytes(residue.name) + " " + detail::quote_bytes(chain.name) + " " +
         std::to_string(residue.seqid.num.value) + ")";
}

/// Water as simulation packages name it, besides the PDB's names that gemmi knows (HOH, WAT, DOD, H2O): CHARMM's
/// TIP3 (TIP when cut to three columns), TIP4, TIP5, AMBER's T3P, T4P, T5P and GROMACS's SOL.
bool is_force_field_water(const std::string& name) {
  for (const std::string_view water : {"TIP", "TIP3", "TIP4", "TIP5", "T3P", "T4P", "T5P", "SOL"}) {
    if (name == water) return true;
  }
  return false;
}

bool is_water(const gemmi::Residue& residue) {
  return residue.is_water() || residue.entity_type == gemmi::EntityType::Water || is_force_field_water(residue.name);
}
bool is_ligand(const gemmi::Residue& residue) {
  if (is_water(residue)) return false;
  switch (residue.entity_type) {
    case gemmi::EntityType::NonPolymer:
    case gemmi::EntityType::Branched: return true;
    case gemmi::EntityType::Polymer: return false;
    default: return residue.het_flag == 'H';
  }
}

/// Indices of the atoms of `residue` that survive the altloc choice: every atom without an altloc, and per
/// atom name the altloc with the highest occupancy (the first on a tie).
std::vector<bool> chosen_conformers(const gemmi::Residue& residue) {
  std::vector<bool> keep(residue.atoms.size(), true);
  std::unordered_map<std::string, std::size_t> best;  // atom name → index of its best altloc so far
  for (std::size_t i = 0; i < residue.atoms.size(); ++i) {
    const gemmi::Atom& a = residue.atoms[i];
    if (a.altloc == '\0') continue;
    const auto [it, first] = best.emplace(a.name, i);
    if (first) continue;
    if (a.occ > residue.atoms[it->second].occ) {
      keep[it->second] = false;
      it->second = i;
    } else {
      keep[i] = false;
    }
  }
  return keep;
}

/// Per residue of `chain`, whether its atoms with an altloc are another residue's alternative (microheterogeneity:
/// SER with altloc A and THR with altloc B at one position, which gemmi reads as two residues of the same number).
/// Of the residues sharing a number, the one whose altloc atoms reach the highest occupancy keeps them (the first
/// on a tie); atoms without an altloc belong to every alternative and are kept.
std::vector<bool> alternative_residues(const gemmi::Chain& chain) {
  const auto& residues = chain.residues;
  std::vector<bool> alternative(residues.size(), false);
  const auto altloc_occupancy = [](const gemmi::Residue& r) {
    double best = -1;
    for (const gemmi::Atom& a : r.atoms) {
      if (a.altloc != '\0') best = std::max(best, static_cast<double>(a.occ));
    }
    return best;  // −1: no atom with an altloc
  };
  for (std::size_t first = 0; first < residues.size();) {
    std::size_t end = first + 1;
    while (end < residues.size() && residues[end].seqid == residues[first].seqid) ++end;
    if (end - first > 1) {
      std::size_t kept = first;
      for (std::size_t r = first + 1; r < end; ++r) {
        if (altloc_occupancy(residues[r]) > altloc_occupancy(residues[kept])) kept = r;
      }
      for (std::size_t r = first; r < end; ++r) alternative[r] = r != kept && altloc_occupancy(residues[r]) >= 0;
    }
    first = end;
  }
  return alternative;
}

bool structure_has_atoms(const gemmi::Structure& structure) {
  for (const gemmi::Chain& chain : structure.models.front().chains) {
    for (const gemmi::Residue& residue : chain.residues) {
      if (!residue.atoms.empty()) return true;
    }
  }
  return false;
}

/// The assembly id as messages quote it (ids from the options are plain; others are escaped).
std::string quoted_assembly(const std::string& id) {
  return "'" + detail::quote_bytes(id, max_assembly_id_chars) + "'";
}

/// Where a format lists its assemblies, as messages name it.
struct assembly_listing {
  const char* records;  ///< "REMARK 350 BIOMOLECULE" or "_pdbx_struct_assembly"
  /// mmCIF: the assembly ids of the _pdbx_struct_assembly loop, also those gemmi could not read
  std::vector<std::string> listed_ids;
};

std::string assembly_ids(const gemmi::Structure& structure) {
  std::string ids;
  for (const gemmi::Assembly& assembly : structure.assemblies) {
    ids += (ids.empty() ? "" : ", ") + detail::quote_bytes(assembly.name, max_assembly_id_chars);
  }
  return ids;
}

status unknown_assembly(const gemmi::Structure& structure, const std::string& id, const assembly_listing& listing) {
  const std::string asked = "assembly " + quoted_assembly(id);
  const std::string deposited = std::string(deposited_assembly) + " (the file's own coordinates)";
  if (std::find(listing.listed_ids.begin(), listing.listed_ids.end(), id) != listing.listed_ids.end()) {
    return {errc::invalid_input, asked + " is in " + listing.records + " but was not read: the loop needs the "
                                     "columns id, details, method_details, oligomeric_details and oligomeric_count, "
                                     "details an author or software defined assembly"};
  }
  if (structure.assemblies.empty()) {
    return {errc::invalid_input, asked + ": the file lists no assembly (" + listing.records + "); only " + deposited +
                                     " can be meshed"};
  }
  return {errc::invalid_input, asked + " is not in the file: its assemblies are " + assembly_ids(structure) +
                                   ", or " + deposited};
}

/// A rotation's matrix is orthonormal: MᵀM = I. Rounded to the 5 or 6 decimals files give, it is within 1e-5;
/// a damaged digit moves an entry by 0.1 or more.
constexpr double max_rotation_error = 0.01;

status check_operator(const gemmi::Assembly::Operator& op, std::size_t index, const std::string& id) {
  const gemmi::Transform& t = op.transform;
  const std::string name = "assembly " + quoted_assembly(id) + ", operator " + std::to_string(index + 1) +
                           (op.name.empty() ? "" : " ('" + detail::quote_bytes(op.name, 24) + "')");
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(t.vec.at(i))) return {errc::invalid_input, name + ": its translation is not a number"};
    for (int j = 0; j < 3; ++j) {
      if (!std::isfinite(t.mat[i][j])) return {errc::invalid_input, name + ": its matrix is not all numbers"};
    }
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += t.mat[k][i] * t.mat[k][j];
      if (std::fabs(dot - (i == j ? 1.0 : 0.0)) > max_rotation_error) {
        return {errc::invalid_input, name + ": its matrix is not a rotation (its columns are not orthonormal)"};
      }
    }
  }
  return status::success();
}

/// Atoms of `model` that `gen` copies (every atom of its chains or subchains, before the options drop any), as
/// gemmi::make_assembly selects them.
std::size_t generator_atoms(const gemmi::Model& model, const gemmi::Assembly::Gen& gen) {
  const bool all_chains = !gen.chains.empty() && gen.chains.front() == "(all)";
  std::size_t atoms = 0;
  for (const gemmi::Chain& chain : model.chains) {
    const bool whole_chain = all_chains || gemmi::in_vector(chain.name, gen.chains);
    for (const gemmi::Residue& residue : chain.residues) {
      if (whole_chain || gemmi::in_vector(residue.subchain, gen.subchains)) atoms += residue.atoms.size();
    }
  }
  return atoms;
}

std::string generator_targets(const gemmi::Assembly::Gen& gen) {
  const bool by_chain = !gen.chains.empty();
  std::string names;
  for (const std::string& name : by_chain ? gen.chains : gen.subchains) {
    names += (names.empty() ? "" : ", ") + detail::quote_bytes(name, 8);
  }
  return (by_chain ? "chains " : "label_asym_id subchains ") + names;
}

struct built_assembly {
  gemmi::Model model;
  std::size_t operators = 0;
  std::size_t merged_atoms = 0;
};

std::size_t atom_count(const gemmi::Model& model) {
  std::size_t atoms = 0;
  for (const gemmi::Chain& chain : model.chains) {
    for (const gemmi::Residue& residue : chain.residues) atoms += residue.atoms.size();
  }
  return atoms;
}

/// The assembly `id` of `structure`, once its operators and generators are checked on the first model as the
/// file gives it (pdb_mmcif_reader.hpp).
result<const gemmi::Assembly*> checked_assembly(const gemmi::Structure& structure, const std::string& id,
                                                const assembly_listing& listing) {
  const auto found = std::find_if(structure.assemblies.begin(), structure.assemblies.end(),
                                  [&](const gemmi::Assembly& a) { return a.name == id; });
  if (found == structure.assemblies.end()) return unknown_assembly(structure, id, listing);
  std::size_t operators = 0;
  for (const gemmi::Assembly::Gen& gen : found->generators) {
    for (const gemmi::Assembly::Operator& op : gen.operators) {
      if (status checked = check_operator(op, operators, id); !checked) return checked;
      ++operators;
    }
    if (generator_atoms(structure.models.front(), gen) == 0) {
      return status{errc::invalid_input, "assembly " + quoted_assembly(id) + " applies its operators to " +
                                             generator_targets(gen) + ", which have no atom in the file's first model"};
    }
  }
  if (operators == 0) {
    return status{errc::invalid_input, "assembly " + quoted_assembly(id) + " has no symmetry operator"};
  }
  return &*found;
}

std::size_t operator_count(const gemmi::Assembly& assembly) {
  std::size_t operators = 0;
  for (const gemmi::Assembly::Gen& gen : assembly.generators) operators += gen.operators.size();
  return operators;
}

/// `assembly` built from `model` (the atoms the options keep), its size checked against limits.max_atoms first.
result<built_assembly> build_assembly(const gemmi::Assembly& assembly, const gemmi::Model& model,
                                      const mesh_limits& limits) {
  std::size_t atoms = 0;
  for (const gemmi::Assembly::Gen& gen : assembly.generators) {
    atoms += generator_atoms(model, gen) * gen.operators.size();
  }
  const std::size_t operators = operator_count(assembly);
  if (atoms > limits.max_atoms) {
    return status{errc::limit_exceeded, "assembly " + quoted_assembly(assembly.name) + " has " +
                                            std::to_string(atoms) + " atoms (" + std::to_string(operators) +
                                            " operators), more than " + std::to_string(limits.max_atoms) +
                                            " (limits.max_atoms)"};
  }
  // AddNumber: every copy of chain A is a chain of its own (A1, A2, ...), whatever the count; Short runs out of
  // names after 3,906 chains.
  built_assembly built{gemmi::make_assembly(assembly, model, gemmi::HowToNameCopiedChain::AddNumber, nullptr),
                       operators, 0};
  // An atom on a symmetry axis (an ion on a 5-fold axis) is placed by several operators at one position: kept
  // once, as gemmi's transform_to_assembly does, or the Gaussian density would count it once per copy.
  const std::size_t copied = atom_count(built.model);
  gemmi::merge_atoms_in_expanded_model(built.model, gemmi::UnitCell());
  built.merged_atoms = copied - atom_count(built.model);
  return built;
}

/// Drops from `model` the atoms the options do not keep: waters, ligands and hydrogens as asked, and the
/// alternate locations not chosen (chosen_conformers, alternative_residues).
void keep_chosen_atoms(gemmi::Model& model, const structure_options& options) {
  for (gemmi::Chain& chain : model.chains) {
    const std::vector<bool> alternative = alternative_residues(chain);
    for (std::size_t r = 0; r < chain.residues.size(); ++r) {
      gemmi::Residue& residue = chain.residues[r];
      if (is_water(residue) ? !options.keep_waters : is_ligand(residue) && !options.keep_ligands) {
        residue.atoms.clear();
        continue;
      }
      const std::vector<bool> keep = chosen_conformers(residue);
      std::vector<gemmi::Atom> kept;
      kept.reserve(residue.atoms.size());
      for (std::size_t i = 0; i < residue.atoms.size(); ++i) {
        const gemmi::Atom& a = residue.atoms[i];
        if (!keep[i] || (alternative[r] && a.altloc != '\0')) continue;
        if (a.is_hydrogen() && !options.keep_hydrogens) continue;
        kept.push_back(a);
      }
      residue.atoms = std::move(kept);
    }
  }
}

/// Appends every atom of `model` to `mol` with its radius from the table, each checked (element, radius,
/// occupancy, coordinate range) and named as the model names it when it fails.
status append_atoms(const gemmi::Model& model, const structure_options& options, const mesh_limits& limits,
                    molecule& mol) {
  for (const gemmi::Chain& chain : model.chains) {
    for (const gemmi::Residue& residue : chain.residues) {
      for (const gemmi::Atom& a : residue.atoms) {
        if (a.element == gemmi::El::X) {
          return {errc::invalid_input, atom_label(chain, residue, a) + ": no element (no element symbol, and none "
                                                                         "follows from the atom name)"};
        }
        const std::optional<double> radius = vdw_radius(options.radii, a.element.name());
        if (!radius) {
          return {errc::invalid_input, atom_label(chain, residue, a) + ": element " + a.element.name() +
                                           " has no radius in the " + std::string(radii_set_name(options.radii)) +
                                           " set (choose another radii set, drop ligands, or give radii in a PQR "
                                           "file)"};
        }
        atom parsed;
        parsed.center = {a.pos.x, a.pos.y, a.pos.z};
        parsed.radius = *radius;
        if (std::isnan(a.occ)) {
          return {errc::invalid_input, atom_label(chain, residue, a) + ": occupancy is not a number"};
        }
        if (std::string problem = detail::atom_range_problem(parsed, limits); !problem.empty()) {
          return {errc::invalid_input, atom_label(chain, residue, a) + ": " + problem};
        }
        detail::add_atom(mol, parsed);
      }
    }
  }
  return status::success();
}

/// The atoms of the first model, or of the assembly the options ask for, that the options keep, with radii from
/// the table. The deposited atoms are checked first, so that an error names an atom as the file does.
result<structure_read> atoms_of(gemmi::Structure& structure, const structure_options& options,
                                const mesh_limits& limits, std::string_view records,
                                const assembly_listing& listing) {
  structure_read read;
  if (structure.models.empty()) return detail::check_something_to_mesh(read.mol, records);
  gemmi::add_entity_types(structure, /*overwrite=*/false);
  const gemmi::Assembly* assembly = nullptr;
  if (options.assembly != deposited_assembly) {
    result<const gemmi::Assembly*> checked = checked_assembly(structure, options.assembly, listing);
    if (!checked) return checked.error();
    assembly = *checked;
  }
  const bool had_atoms = structure_has_atoms(structure);
  const auto check_usable = [&](const molecule& mol) -> status {
    status usable = detail::check_something_to_mesh(mol, records);
    if (usable || !mol.atoms.empty() || !had_atoms) return usable;
    return {errc::nothing_to_mesh, "no atoms with radius > 0: the options dropped every atom (waters " +
                                       std::string(options.keep_waters ? "kept" : "dropped") + ", ligands " +
                                       (options.keep_ligands ? "kept" : "dropped") + ", hydrogens " +
                                       (options.keep_hydrogens ? "kept" : "dropped") + ")"};
  };
  gemmi::Model& deposited = structure.models.front();
  keep_chosen_atoms(deposited, options);
  if (status appended = append_atoms(deposited, options, limits, read.mol); !appended) return appended;
  if (status usable = check_usable(read.mol); !usable) return usable;
  if (!assembly) return read;

  result<built_assembly> built = build_assembly(*assembly, deposited, limits);
  if (!built) return built.error();
  read.mol = molecule{};
  read.assembly_operators = built->operators;
  read.assembly_merged_atoms = built->merged_atoms;
  if (status appended = append_atoms(built->model, options, limits, read.mol); !appended) return appended;
  if (status usable = check_usable(read.mol); !usable) return usable;
  return read;
}

/// quote_bytes of as many leading bytes of `bytes` as fit in `max_chars` characters once escaped (an escaped byte
/// takes 4): gemmi's messages quote the input, which may be all backslashes (a fuzz find: a message of 643
/// characters, where the readers promise one line of at most 400).
std::string quote_within(std::string_view bytes, std::size_t max_chars) {
  std::size_t chars = 0;
  std::size_t taken = 0;
  for (; taken < bytes.size(); ++taken) {
    const auto c = static_cast<unsigned char>(bytes[taken]);
    const std::size_t width = c >= 0x20 && c < 0x7F && c != '\\' ? 1 : 4;
    if (chars + width > max_chars) break;
    chars += width;
  }
  return detail::quote_bytes(bytes, taken);
}

status gemmi_error(std::string_view format, const std::exception& error) {
  return {errc::invalid_input, std::string(format) + ": " + quote_within(error.what(), max_gemmi_message_chars)};
}

/// "input:4:14: unterminated 'string'" (gemmi's CIF syntax error) → "line 4: column 14: unterminated 'string'".
status cif_syntax_error(const std::exception& error) {
  std::string_view message = error.what();
  constexpr std::string_view source = "input:";
  if (message.substr(0, source.size()) == source) {
    message.remove_prefix(source.size());
    const std::size_t line_end = message.find(':');
    const std::size_t column_end = line_end == std::string_view::npos ? line_end : message.find(':', line_end + 1);
    if (column_end != std::string_view::npos) {
      return {errc::invalid_input,
              "line " + quote_within(message.substr(0, line_end), 20) + ": column " +
                  quote_within(message.substr(line_end + 1, column_end - line_end - 1), 20) + ": mmCIF syntax:" +
                  quote_within(message.substr(column_end + 1), max_gemmi_message_chars)};
    }
  }
  return gemmi_error("mmCIF syntax", error);
}

/// The _atom_site columns that the atoms' coordinates and elements need; a loop without some is refused naming
/// every one missing. Atom and residue names are needed too (alternate locations, waters, ligands): the
/// label_ or the auth_ column of each.
constexpr const char* required_atom_site_tags[] = {"_atom_site.type_symbol", "_atom_site.Cartn_x",
                                                   "_atom_site.Cartn_y", "_atom_site.Cartn_z"};
constexpr std::pair<const char*, const char*> required_atom_site_alternatives[] = {
    {"_atom_site.label_atom_id", "_atom_site.auth_atom_id"}, {"_atom_site.label_comp_id", "_atom_site.auth_comp_id"}};

/// Columns gemmi's make_structure insists on but the mesh does not need (gemmi silently reads no atom without
/// them): a loop without one gets it, each row's value copied from `copied_from` when the loop has that column,
/// else `value` ('.': not applicable, so no alternate location; occupancy 1: the atom is there).
struct filled_atom_site_column {
  const char* tag;
  const char* copied_from;
  const char* value;
};
constexpr filled_atom_site_column filled_atom_site_columns[] = {
    {"_atom_site.id", nullptr, "."},
    {"_atom_site.label_alt_id", nullptr, "."},
    {"_atom_site.label_asym_id", "_atom_site.auth_asym_id", "."},
    {"_atom_site.occupancy", nullptr, "1"},
    {"_atom_site.B_iso_or_equiv", nullptr, "?"},
    {"_atom_site.auth_seq_id", "_atom_site.label_seq_id", "."}};

/// Whether `block` has any _atom_site column.
bool has_atom_site(const gemmi::cif::Block& block) {
  for (const char* tag : required_atom_site_tags) {
    if (block.has_tag(tag)) return true;
  }
  for (const filled_atom_site_column& column : filled_atom_site_columns) {
    if (block.has_tag(column.tag)) return true;
  }
  return false;
}

/// The _atom_site loop gemmi can read, once filled_atom_site_columns are added: every missing required column
/// named in one error.
status check_atom_site(gemmi::cif::Block& block, const mesh_limits& limits) {
  if (!has_atom_site(block)) return status::success();  // no atoms: reported as nothing to mesh
  std::vector<std::string> missing;
  for (const char* tag : required_atom_site_tags) {
    if (!block.find_values(tag).item()) missing.emplace_back(tag);
  }
  for (const auto& [label, auth] : required_atom_site_alternatives) {
    if (!block.find_values(label).item() && !block.find_values(auth).item()) {
      missing.push_back(std::string(label) + " (or " + auth + ")");
    }
  }
  if (!missing.empty()) {
    std::string names;
    for (const std::string& name : missing) names += (names.empty() ? "" : ", ") + name;
    return {errc::invalid_input, "mmCIF _atom_site has no " + names + (missing.size() == 1 ? " column" : " columns")};
  }
  const gemmi::cif::Column xs = block.find_values("_atom_site.Cartn_x");
  if (static_cast<std::size_t>(xs.length()) > limits.max_atoms) {
    return {errc::limit_exceeded, "mmCIF _atom_site has " + std::to_string(xs.length()) + " atoms, more than " +
                                      std::to_string(limits.max_atoms) + " (limits.max_atoms)"};
  }
  return status::success();
}

/// Adds the filled_atom_site_columns that `block`'s _atom_site (a loop, or single pairs) lacks.
void fill_atom_site_columns(gemmi::cif::Block& block) {
  gemmi::cif::Loop* loop = block.find_values("_atom_site.Cartn_x").get_loop();
  for (const filled_atom_site_column& column : filled_atom_site_columns) {
    if (block.find_values(column.tag).item()) continue;
    if (!loop) {
      const std::string* copied = column.copied_from ? block.find_value(column.copied_from) : nullptr;
      block.set_pair(column.tag, copied ? *copied : column.value);
      continue;
    }
    const int source = column.copied_from ? loop->find_tag(column.copied_from) : -1;
    const std::size_t width = loop->width();
    std::vector<std::string> values;
    values.reserve(loop->values.size() + loop->length());
    for (std::size_t row = 0; row < loop->length(); ++row) {
      values.insert(values.end(), loop->values.begin() + static_cast<std::ptrdiff_t>(row * width),
                    loop->values.begin() + static_cast<std::ptrdiff_t>((row + 1) * width));
      values.push_back(source >= 0 ? loop->val(row, static_cast<std::size_t>(source)) : column.value);
    }
    loop->values = std::move(values);
    loop->tags.emplace_back(column.tag);
  }
}

/// The mmCIF categories that gemmi's make_structure reads (gemmi 0.5.7, mmcif.hpp), lower case.
constexpr std::string_view gemmi_mmcif_categories[] = {
    "_atom_site.", "_atom_site_anisotrop.", "_atom_sites.", "_audit_author.", "_cell.", "_database_pdb_matrix.",
    "_database_pdb_rev.", "_diffrn.", "_diffrn_detector.", "_diffrn_radiation.", "_diffrn_source.", "_entity.",
    "_entity_poly.", "_entity_poly_seq.", "_entry.", "_exptl.", "_exptl_crystal.", "_pdbx_database_status.",
    "_pdbx_sifts_xref_db.", "_pdbx_struct_assembly.", "_pdbx_struct_assembly_gen.", "_pdbx_struct_assembly_prop.",
    "_pdbx_struct_oper_list.", "_pdbx_struct_sheet_hbond.", "_refine.", "_reflns.", "_software.", "_struct.",
    "_struct_asym.", "_struct_conf.", "_struct_conn.", "_struct_keywords.", "_struct_mon_prot_cis.",
    "_struct_ncs_oper.", "_struct_ref.", "_struct_ref_seq.", "_struct_sheet.", "_struct_sheet_order.",
    "_struct_sheet_range."};

bool is_read_by_make_structure(std::string_view tag) {
  const std::size_t dot = tag.find('.');
  if (dot == std::string_view::npos) return false;
  std::string category(tag.substr(0, dot + 1));
  std::transform(category.begin(), category.end(), category.begin(),
                 [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; });
  return std::find(std::begin(gemmi_mmcif_categories), std::end(gemmi_mmcif_categories), category) !=
         std::end(gemmi_mmcif_categories);
}

/// Refuses the integers gemmi would overflow on, in the categories make_structure reads of the first block.
status check_gemmi_integers(const gemmi::cif::Block& block) {
  const auto check = [](const std::string& tag, const std::string& raw) -> status {
    if (!overflows_gemmi_int(gemmi::cif::as_string(raw))) return status::success();
    return {errc::invalid_input, "mmCIF " + detail::quote_bytes(tag, 40) + " '" + detail::quote_bytes(raw, 24) +
                                     "' is an integer beyond the 32-bit range"};
  };
  for (const gemmi::cif::Item& item : block.items) {
    if (item.type == gemmi::cif::ItemType::Pair && is_read_by_make_structure(item.pair[0])) {
      if (status checked = check(item.pair[0], item.pair[1]); !checked) return checked;
    } else if (item.type == gemmi::cif::ItemType::Loop) {
      const gemmi::cif::Loop& loop = item.loop;
      const std::size_t width = loop.tags.size();
      for (std::size_t column = 0; column < width; ++column) {
        if (!is_read_by_make_structure(loop.tags[column])) continue;
        for (std::size_t at = column; at < loop.values.size(); at += width) {
          if (status checked = check(loop.tags[column], loop.values[at]); !checked) return checked;
        }
      }
    }
  }
  return status::success();
}



/// What the mmCIF generator rows of the requested assembly name.
struct requested_generators {
  /// Per _pdbx_struct_assembly_gen row of the requested assembly, in file order, its operators (groups composed);
  /// empty for deposited_assembly.
  std::vector<std::vector<gemmi::Assembly::Operator>> rows;
  std::vector<std::string> listed_ids;  ///< _pdbx_struct_assembly.id values, for unknown_assembly
};

/// The operators of _pdbx_struct_oper_list by id (rows with an id, the 9 matrix and the 3 vector columns).
std::unordered_map<std::string, gemmi::Transform> operator_list(gemmi::cif::Block& block) {
  std::vector<std::string> tags = {"id"};  // then matrix[i][1..3] and vector[i], row by row: column 1 + 4 i + j
  for (int i = 1; i <= 3; ++i) {
    for (int j = 1; j <= 3; ++j) tags.push_back("matrix[" + std::to_string(i) + "][" + std::to_string(j) + "]");
    tags.push_back("vector[" + std::to_string(i) + "]");
  }
  std::unordered_map<std::string, gemmi::Transform> operators;
  for (const auto row : block.find("_pdbx_struct_oper_list.", tags)) {
    gemmi::Transform transform;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) transform.mat[i][j] = gemmi::cif::as_number(row[1 + 4 * i + j]);
      transform.vec.at(i) = gemmi::cif::as_number(row[1 + 4 * i + 3]);
    }
    operators.emplace(row.str(0), transform);
  }
  return operators;
}

/// The Cartesian product of operator groups, applied from right to left (mmCIF's oper_expression "(X0)(1-60)":
/// each of 1 to 60, then X0), the first group varying slowest; named "X0x1", ...
std::vector<gemmi::Assembly::Operator> composed_operators(
    const std::vector<std::vector<std::string>>& groups,
    const std::unordered_map<std::string, gemmi::Transform>& transforms) {
  std::vector<gemmi::Assembly::Operator> composed(1);  // the identity, named ""
  for (const std::vector<std::string>& group : groups) {
    std::vector<gemmi::Assembly::Operator> next;
    next.reserve(composed.size() * group.size());
    for (const gemmi::Assembly::Operator& left : composed) {
      for (const std::string& id : group) {
        gemmi::Assembly::Operator op;
        op.name = left.name.empty() ? id : left.name + "x" + id;
        op.transform = left.transform.combine(transforms.at(id));
        next.push_back(std::move(op));
      }
    }
    composed = std::move(next);
  }
  return composed;
}

/// The checks of the generator rows before gemmi reads them (assembly_records.hpp): every oper_expression is
/// bounded for gemmi's parser (its ids over all rows at most limits.max_atoms); those of the requested assembly
/// are parsed strictly, each id must be in _pdbx_struct_oper_list, and their operators are composed here (gemmi
/// reads only the first group of a product).
result<requested_generators> check_assembly_generators(gemmi::cif::Block& block, const std::string& assembly,
                                                       const mesh_limits& limits) {
  requested_generators requested;
  for (const std::string& raw : block.find_values("_pdbx_struct_assembly.id")) {
    requested.listed_ids.push_back(gemmi::cif::as_string(raw));
  }
  const bool wants_assembly = assembly != deposited_assembly;
  const std::unordered_map<std::string, gemmi::Transform> transforms =
      wants_assembly ? operator_list(block) : std::unordered_map<std::string, gemmi::Transform>();
  std::size_t budget = limits.max_atoms;            // ids gemmi may still make
  std::size_t requested_budget = limits.max_atoms;  // operators the requested assembly may still have
  for (const auto row : block.find("_pdbx_struct_assembly_gen.", {"assembly_id", "oper_expression"})) {
    const std::string expression = row.str(1);
    result<std::size_t> made = detail::gemmi_operator_id_count(expression, budget);
    if (!made) return made.error();
    budget -= *made;
    if (!wants_assembly || row.str(0) != assembly) continue;
    result<std::vector<std::vector<std::string>>> groups = detail::operator_groups(expression, requested_budget);
    if (!groups) return groups.error();
    for (const std::vector<std::string>& group : *groups) {
      for (const std::string& id : group) {
        if (transforms.count(id) == 0) {
          return status{errc::invalid_input, "mmCIF assembly " + quoted_assembly(assembly) + ": operator '" +
                                                 detail::quote_bytes(id, 24) + "' of oper_expression '" +
                                                 detail::quote_bytes(expression, 40) +
                                                 "' is not in _pdbx_struct_oper_list (with id, matrix[i][j] and "
                                                 "vector[i])"};
        }
      }
    }
    requested.rows.push_back(composed_operators(*groups, transforms));
    requested_budget -= requested.rows.back().size();
  }
  return requested;
}

}  // namespace

result<structure_read> read_pdb_structure(std::string_view text, const structure_options& options,
                                          const mesh_limits& limits) {
  if (status checked = check_pdb_text(text, limits); !checked) return checked;
  const bool wants_assembly = options.assembly != deposited_assembly;
  std::size_t biomt_operators = 0;
  if (wants_assembly) {
    result<std::size_t> operators = detail::check_biomt_records(text, options.assembly, limits.max_line_bytes);
    if (!operators) return operators.error();
    biomt_operators = *operators;
  }
  const std::string prepared = text_for_gemmi(text);
  const std::string_view input = prepared.empty() ? text : std::string_view(prepared);
  try {
    gemmi::Structure structure = gemmi::read_pdb_from_memory(input.data(), input.size(), "input");
    if (const gemmi::Assembly* assembly = wants_assembly ? structure.find_assembly(options.assembly) : nullptr;
        assembly && operator_count(*assembly) != biomt_operators) {
      // check_biomt_records follows gemmi's rules; a difference means they drifted apart.
      return status{errc::invalid_input, "REMARK 350 biomolecule " + quoted_assembly(options.assembly) +
                                             ": the BIOMT check found " + std::to_string(biomt_operators) +
                                             " operators, gemmi read " + std::to_string(operator_count(*assembly))};
    }
    return atoms_of(structure, options, limits, "ATOM or HETATM record", {"REMARK 350 BIOMOLECULE", {}});
  } catch (const std::runtime_error& error) {
    return gemmi_error("PDB", error);
  } catch (const std::logic_error& error) {  // gemmi's number parsers throw std::invalid_argument
    return gemmi_error("PDB", error);
  }
}

result<structure_read> read_mmcif_structure(std::string_view text, const structure_options& options,
                                            const mesh_limits& limits) {
  if (text.find('\0') != std::string_view::npos) {
    return status{errc::invalid_input, "NUL byte (binary data, not mmCIF text)"};
  }
  gemmi::cif::Document document;
  try {
    document = gemmi::cif::read_memory(text.data(), text.size(), "input");
  } catch (const std::runtime_error& error) {
    return cif_syntax_error(error);
  }
  try {
    if (document.blocks.empty()) return status{errc::nothing_to_mesh, "no atoms with radius > 0: no mmCIF data block"};
    // The coordinates are the first block's; later blocks (restraints, other entries) are not read.
    gemmi::cif::Block& first = document.blocks.front();
    if (!has_atom_site(first)) {
      for (std::size_t b = 1; b < document.blocks.size(); ++b) {
        if (has_atom_site(document.blocks[b])) {
          return status{errc::invalid_input, "mmCIF: the first data block has no _atom_site, block " +
                                                 std::to_string(b + 1) + " has: the coordinates are read from the "
                                                 "first block"};
        }
      }
    }
    if (status checked = check_atom_site(first, limits); !checked) return checked;
    if (has_atom_site(first)) fill_atom_site_columns(first);
    if (status checked = check_gemmi_integers(first); !checked) return checked;
    result<requested_generators> generators = check_assembly_generators(first, options.assembly, limits);
    if (!generators) return generators.error();
    gemmi::Structure structure = gemmi::make_structure_from_block(first);
    document = gemmi::cif::Document();  // free the text's copy before the atoms are made
    if (gemmi::Assembly* assembly =
            options.assembly != deposited_assembly ? structure.find_assembly(options.assembly) : nullptr) {
      // gemmi made one generator per row of the assembly (when the loop has assembly_id, oper_expression and
      // asym_id_list); their operators are those composed from the rows.
      if (assembly->generators.size() != generators->rows.size()) {
        return status{errc::invalid_input, "mmCIF assembly " + quoted_assembly(options.assembly) + ": " +
                                               std::to_string(generators->rows.size()) +
                                               " _pdbx_struct_assembly_gen rows, of which " +
                                               std::to_string(assembly->generators.size()) +
                                               " were read (the loop needs assembly_id, oper_expression and "
                                               "asym_id_list)"};
      }
      for (std::size_t g = 0; g < generators->rows.size(); ++g) {
        assembly->generators[g].operators = std::move(generators->rows[g]);
      }
    }
    return atoms_of(structure, options, limits, "_atom_site row",
                    {"_pdbx_struct_assembly", std::move(generators->listed_ids)});
  } catch (const std::runtime_error& error) {
    return gemmi_error("mmCIF", error);
  } catch (const std::logic_error& error) {  // gemmi's as_int throws std::invalid_argument (a fuzz find: it
    return gemmi_error("mmCIF", error);      // terminated tracemeshd on an upload with auth_seq_id ';')
  }
}

result<molecule> parse_pdb(std::string_view text, const structure_options& options, const mesh_limits& limits) {
  result<structure_read> read = read_pdb_structure(text, options, limits);
  if (!read) return read.error();
  return std::move(read->mol);
}

result<molecule> parse_mmcif(std::string_view text, const structure_options& options, const mesh_limits& limits) {
  result<structure_read> read = read_mmcif_structure(text, options, limits);
  if (!read) return read.error();
  return std::move(read->mol);
}

}  // namespace tracemesh
