#include "core/io/structure/pdb_mmcif_reader.hpp"

#include <gtest/gtest.h>

#include <string>

#include "core/io/structure/molecule_reader.hpp"

namespace tracemesh {
namespace {

/// One PDB atom record in fixed columns.
std::string pdb_atom(const char* record, int serial, const char* name, char altloc, const char* residue, int number,
                     double x, double y, double z, double occupancy, const char* element) {
  char line[100];
  std::snprintf(line, sizeof line, "%-6s%5d %-4s%c%3s A%4d    %8.3f%8.3f%8.3f%6.2f%6.2f          %2s\n", record,
                serial, name, altloc, residue, number, x, y, z, occupancy, 10.0, element);
  return line;
}

molecule parse_ok(const std::string& pdb, const structure_options& options = {}) {
  result<molecule> mol = parse_pdb(pdb, options);
  EXPECT_TRUE(mol.ok()) << mol.error().message();
  return mol.ok() ? *mol : molecule{};
}

const std::string peptide = pdb_atom("ATOM", 1, " N", ' ', "GLY", 1, 1, 2, 3, 1, "N") +
                            pdb_atom("ATOM", 2, " CA", ' ', "GLY", 1, 2.5, 2, 3, 1, "C") +
                            pdb_atom("ATOM", 3, " HA2", ' ', "GLY", 1, 2.5, 3, 3, 1, "H") +
                            pdb_atom("ATOM", 4, " C", ' ', "GLY", 1, 3.5, 2, 3, 1, "C") +
                            pdb_atom("ATOM", 5, " O", ' ', "GLY", 1, 4.5, 2, 3, 1, "O") +
                            pdb_atom("ATOM", 6, " N", ' ', "ALA", 2, 3.5, 1, 3, 1, "N") +
                            pdb_atom("ATOM", 7, " CA", ' ', "ALA", 2, 3.5, 0, 3, 1, "C") +
                            pdb_atom("ATOM", 8, " C", ' ', "ALA", 2, 3.5, -1, 3, 1, "C") +
                            pdb_atom("ATOM", 9, " O", ' ', "ALA", 2, 4.5, -1, 3, 1, "O");
const std::string ligand_and_water = "TER\n" + pdb_atom("HETATM", 10, "ZN", ' ', " ZN", 101, 9, 9, 9, 1, "ZN") +
                                     pdb_atom("HETATM", 11, " O", ' ', "HOH", 201, -9, -9, -9, 1, "O");

TEST(PdbReader, ReadsAtomsWithBondiRadiiInFileOrder) {
  const molecule mol = parse_ok(peptide);
  ASSERT_EQ(mol.atoms.size(), 9u);
  EXPECT_EQ(mol.atoms[0].center.x, 1.0);
  EXPECT_EQ(mol.atoms[0].radius, 1.55);  // N
  EXPECT_EQ(mol.atoms[1].radius, 1.70);  // C
  EXPECT_EQ(mol.atoms[2].radius, 1.20);  // H
  EXPECT_EQ(mol.atoms[4].radius, 1.52);  // O
  EXPECT_EQ(mol.atoms[8].center.x, 4.5);
  EXPECT_EQ(mol.atoms[8].center.y, -1.0);
  structure_options mantina;
  mantina.radii = radii_set::mantina;
  EXPECT_EQ(parse_ok(peptide, mantina).atoms[2].radius, 1.10);
}

TEST(PdbReader, HydrogensWatersAndLigandsFollowTheOptions) {
  const std::string pdb = peptide + ligand_and_water;
  EXPECT_EQ(parse_ok(pdb).atoms.size(), 10u) << "default: hydrogens and ligands kept, waters dropped";
  structure_options options;
  options.keep_waters = true;
  EXPECT_EQ(parse_ok(pdb, options).atoms.size(), 11u);
  options.keep_ligands = false;
  EXPECT_EQ(parse_ok(pdb, options).atoms.size(), 10u);
  options.keep_hydrogens = false;
  const molecule heavy = parse_ok(pdb, options);
  ASSERT_EQ(heavy.atoms.size(), 9u);
  EXPECT_EQ(heavy.atoms.back().center.x, -9.0) << "the water is kept";

  structure_options waters_only;
  waters_only.keep_ligands = false;
  const result<molecule> none = parse_pdb(ligand_and_water, waters_only);
  EXPECT_EQ(none.error().code(), errc::nothing_to_mesh);
  EXPECT_EQ(none.error().message(),
            "no atoms with radius > 0: the options dropped every atom (waters dropped, ligands dropped, hydrogens "
            "kept)");
}

TEST(PdbReader, WatersNamedBySimulationPackagesAreWatersToo) {
  // CHARMM's TIP3 (TIP in three columns), AMBER's T3P, GROMACS's SOL: a sweep found them meshed by default.
  for (const char* name : {"TIP", "T3P", "SOL", "WAT"}) {
    const std::string pdb = peptide + "TER\n" + pdb_atom("HETATM", 10, " OH2", ' ', name, 201, -9, -9, -9, 1, "O");
    EXPECT_EQ(parse_ok(pdb).atoms.size(), 9u) << name << " is dropped by default";
    structure_options keep;
    keep.keep_waters = true;
    keep.keep_ligands = false;
    EXPECT_EQ(parse_ok(pdb, keep).atoms.size(), 10u) << name << " is a water, not a ligand";
  }
}

TEST(PdbReader, KeepsTheHighestOccupancyAlternateLocation) {
  const std::string pdb = pdb_atom("ATOM", 1, " N", ' ', "SER", 1, 0, 0, 0, 1, "N") +
                          pdb_atom("ATOM", 2, " OG", 'A', "SER", 1, 1, 0, 0, 0.3, "O") +
                          pdb_atom("ATOM", 3, " OG", 'B', "SER", 1, 2, 0, 0, 0.7, "O") +
                          pdb_atom("ATOM", 4, " CB", 'A', "SER", 1, 3, 0, 0, 0.5, "C") +
                          pdb_atom("ATOM", 5, " CB", 'B', "SER", 1, 4, 0, 0, 0.5, "C");
  const molecule mol = parse_ok(pdb);
  ASSERT_EQ(mol.atoms.size(), 3u);
  EXPECT_EQ(mol.atoms[1].center.x, 2.0) << "OG: B has the higher occupancy";
  EXPECT_EQ(mol.atoms[2].center.x, 3.0) << "CB: a tie keeps the first";
}

TEST(PdbReader, KeepsOneResidueWhereAlternateLocationsAreDifferentResidues) {
  // Microheterogeneity: SER with altloc A (0.6) and THR with altloc B (0.4) at residue 10, which gemmi reads as two
  // residues of the same number. Both were meshed, their N, CA, C, O and CB twice (a sweep find); SER alone is kept,
  // with the glycine before it, whose atoms have no altloc. With B the more occupied, THR is kept.
  const auto microheterogeneous = [](double ser, double thr) {
    return pdb_atom("ATOM", 1, " CA", ' ', "GLY", 9, -3, 0, 0, 1, "C") +
           pdb_atom("ATOM", 2, " N", 'A', "SER", 10, 0, 0, 0, ser, "N") +
           pdb_atom("ATOM", 3, " CA", 'A', "SER", 10, 1, 0, 0, ser, "C") +
           pdb_atom("ATOM", 4, " OG", 'A', "SER", 10, 2, 0, 0, ser, "O") +
           pdb_atom("ATOM", 5, " N", 'B', "THR", 10, 0, 1, 0, thr, "N") +
           pdb_atom("ATOM", 6, " CA", 'B', "THR", 10, 1, 1, 0, thr, "C") +
           pdb_atom("ATOM", 7, " OG1", 'B', "THR", 10, 2, 1, 0, thr, "O") +
           pdb_atom("ATOM", 8, " CG2", 'B', "THR", 10, 3, 1, 0, thr, "C");
  };
  const molecule ser = parse_ok(microheterogeneous(0.6, 0.4));
  ASSERT_EQ(ser.atoms.size(), 4u);
  for (std::size_t i = 1; i < 4; ++i) EXPECT_EQ(ser.atoms[i].center.y, 0.0) << "SER's atom " << i;
  const molecule thr = parse_ok(microheterogeneous(0.4, 0.6));
  ASSERT_EQ(thr.atoms.size(), 5u);
  for (std::size_t i = 1; i < 5; ++i) EXPECT_EQ(thr.atoms[i].center.y, 1.0) << "THR's atom " << i;
}

TEST(PdbReader, ReadsOnlyTheFirstModel) {
  const std::string pdb = "MODEL        1\n" + pdb_atom("ATOM", 1, " CA", ' ', "GLY", 1, 0, 0, 0, 1, "C") +
                          "ENDMDL\nMODEL        2\n" + pdb_atom("ATOM", 1, " CA", ' ', "GLY", 1, 5, 0, 0, 1, "C") +
                          "ENDMDL\n";
  const molecule mol = parse_ok(pdb);
  ASSERT_EQ(mol.atoms.size(), 1u);
  EXPECT_EQ(mol.atoms[0].center.x, 0.0);
}

TEST(PdbReader, RejectsBadRecordsNamingTheLineOrAtom) {
  std::string bad_y = pdb_atom("ATOM", 2, " CA", ' ', "GLY", 1, 2.5, 2, 3, 1, "C");
  bad_y.replace(38, 8, "   abc  ");
  std::string bad_occupancy = pdb_atom("ATOM", 2, " CA", ' ', "GLY", 1, 2.5, 2, 3, 1, "C");
  bad_occupancy.replace(54, 6, "  x.yz");
  const struct {
    std::string text, message;
    errc code;
  } cases[] = {
      {"HEADER\n" + bad_y, "line 2: y coordinate 'abc' (columns 39-46) is not a decimal number", errc::invalid_input},
      {bad_occupancy, "line 1: occupancy 'x.yz' (columns 55-60) is not a decimal number", errc::invalid_input},
      {"ATOM      1  CA  GLY A   1       1.000   2.000\n",
       "line 1: atom record of 46 columns; a PDB atom record has x y z in columns 31-54", errc::invalid_input},
      {pdb_atom("ATOM", 7, " FE", ' ', "HEM", 1, 0, 0, 0, 1, "FE"),
       "atom 7 (FE HEM A 1): element Fe has no radius in the bondi set (choose another radii set, drop ligands, or "
       "give radii in a PQR file)",
       errc::invalid_input},
      {pdb_atom("ATOM", 8, " CA", ' ', "GLY", 1, 2e6, 0, 0, 1, "C").replace(30, 8, " 2000000"),
       "line 1: x coordinate 2000000 is beyond +-1e+06 Angstrom (limits.max_abs_coordinate)", errc::invalid_input},
      {"HEADER\nEND\n", "no atoms with radius > 0: the input has no ATOM or HETATM record", errc::nothing_to_mesh},
      // A fuzz find: gemmi shifts the signed chars of every record name (UB for a byte >= 0x80 before C++20).
      {"H\xc4\xbe" "DER    TEST\n" + bad_y, "line 1: record name 'H\\xc4\\xbeDER' (columns 1-6) is not ASCII; PDB text is ASCII",
       errc::invalid_input},
  };
  for (const auto& c : cases) {
    const result<molecule> mol = parse_pdb(c.text);
    ASSERT_FALSE(mol.ok()) << c.text;
    EXPECT_EQ(mol.error().message(), c.message);
    EXPECT_EQ(mol.error().code(), c.code) << c.message;
  }
  mesh_limits two;
  two.max_atoms = 2;
  const result<molecule> over = parse_pdb(peptide, {}, two);
  EXPECT_EQ(over.error().code(), errc::limit_exceeded);
  EXPECT_EQ(over.error().message(), "line 3: more than 2 atoms (limits.max_atoms)");
  EXPECT_EQ(parse_pdb("\x7f" "ELF\x01\x02").error().message(),
            "line 1: control byte 0x7f at column 1 (binary data, not PDB text)");
}

// A fuzz find: gemmi read columns 74-78 of a LINK record of 74-77 columns past the end of the line (ASan: a heap
// read overflow). The reader pads such records; the atoms are read as without the record.
TEST(PdbReader, ShortLinkAndSsbondRecordsAreReadWithinTheirLine) {
  const std::string atom = pdb_atom("ATOM", 1, " CA", ' ', "GLY", 1, 2.5, 2, 3, 1, "C");
  for (const char* record_name : {"LINK", "SSBOND"}) {
    const std::string record = record_name;
    // gemmi's record keeps its line feed: a line of 73 columns is read at columns 74-78 too (a second fuzz find).
    for (std::size_t columns : {73u, 74u, 76u, 77u}) {
      std::string line = record + std::string(columns - record.size() - 2, ' ') + "2.";
      if (columns > 73) line[73] = '2';
      for (const char* end : {"\n", "\r\n"}) {
        const result<molecule> mol = parse_pdb(atom + line + end + atom);
        ASSERT_TRUE(mol.ok()) << record << " " << columns << ": " << mol.error().message();
        EXPECT_EQ(mol->atoms.size(), 2u);
      }
    }
  }
}

// A fuzz find: gemmi reads the sequence numbers of a DBREF2 record (columns 46-55 and 58-67) into an int without
// an overflow check (UBSan: signed overflow), and past the end of a shorter line. Numbers beyond the int range are
// refused naming the line; short DBREF2 records are padded, so they are read as blanks.
TEST(PdbReader, Dbref2SequenceNumbersBeyondTheIntRangeAreRefused) {
  const std::string atom = pdb_atom("ATOM", 1, " CA", ' ', "GLY", 1, 2.5, 2, 3, 1, "C");
  const auto dbref2 = [](const std::string& begin, const std::string& end) {
    std::string line = "DBREF2 1ABC A     P00001" + std::string(45 - 24, ' ');
    line += std::string(10 - begin.size(), ' ') + begin + "  " + std::string(10 - end.size(), ' ') + end + "\n";
    return line;
  };
  EXPECT_TRUE(parse_pdb(atom + dbref2("2147483647", "-999999999") + atom).ok());
  const result<molecule> refused = parse_pdb(dbref2("1", "9999999999") + atom);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().message(),
            "line 1: database sequence end '9999999999' (columns 58-67) is an integer beyond the 32-bit range");
  EXPECT_EQ(refused.error().code(), errc::invalid_input);
  EXPECT_FALSE(parse_pdb("dbre?2" + std::string(39, ' ') + "2147483648\n" + atom).ok()) << "gemmi's record test";
  for (const char* short_record : {"DBREF2\n", "DBREF2 1ABC A     P00001               1\n"}) {
    const result<molecule> mol = parse_pdb(atom + short_record + atom);
    ASSERT_TRUE(mol.ok()) << short_record << mol.error().message();
    EXPECT_EQ(mol->atoms.size(), 2u);
  }
}

const std::string cif_header =
    "data_t\nloop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
    "_atom_site.label_alt_id\n_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.label_entity_id\n"
    "_atom_site.label_seq_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.occupancy\n"
    "_atom_site.B_iso_or_equiv\n_atom_site.auth_seq_id\n_atom_site.auth_asym_id\n";

TEST(MmcifReader, ReadsAtomsAltlocsAndWaters) {
  const std::string cif = cif_header +
                          "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10 1 A\n"
                          "ATOM 2 C CA A GLY A 1 1 2.5 2.0 3.0 0.4 10 1 A\n"
                          "ATOM 3 C CA B GLY A 1 1 2.6 2.0 3.0 0.6 10 1 A\n"
                          "HETATM 4 O O . HOH B 2 . 9.0 9.0 9.0 1.0 10 101 A\n";
  const result<molecule> mol = parse_mmcif(cif);
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  ASSERT_EQ(mol->atoms.size(), 2u);
  EXPECT_EQ(mol->atoms[0].radius, 1.55);
  EXPECT_EQ(mol->atoms[1].center.x, 2.6);
  structure_options waters;
  waters.keep_waters = true;
  EXPECT_EQ(parse_mmcif(cif, waters)->atoms.size(), 3u);
}

TEST(MmcifReader, NeedsOnlyTheColumnsOfCoordinatesElementsAndNames) {
  // No id, label_alt_id, label_asym_id, occupancy, B_iso_or_equiv nor auth_seq_id: gemmi needs them, the mesh
  // does not (as minimal writers such as some docking tools leave them out).
  const std::string minimal = "data_m\nloop_\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
                              "_atom_site.label_comp_id\n_atom_site.label_seq_id\n_atom_site.Cartn_x\n"
                              "_atom_site.Cartn_y\n_atom_site.Cartn_z\n"
                              "N N GLY 1 1.0 2.0 3.0\nC CA GLY 1 2.5 2.0 3.0\nO O HOH . 9.0 9.0 9.0\n";
  const result<molecule> mol = parse_mmcif(minimal);
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  ASSERT_EQ(mol->atoms.size(), 2u) << "the water is dropped by default";
  EXPECT_EQ(mol->atoms[0].radius, 1.55);
  EXPECT_EQ(mol->atoms[1].center.x, 2.5);
  EXPECT_EQ(mol->atoms[1].radius, 1.70);
  structure_options waters;
  waters.keep_waters = true;
  EXPECT_EQ(parse_mmcif(minimal, waters)->atoms.size(), 3u);
  // One atom as single pairs instead of a loop.
  const result<molecule> one = parse_mmcif("data_one\n_atom_site.type_symbol S\n_atom_site.auth_atom_id SG\n"
                                           "_atom_site.auth_comp_id CYS\n_atom_site.Cartn_x 1\n_atom_site.Cartn_y 2\n"
                                           "_atom_site.Cartn_z 3\n");
  ASSERT_TRUE(one.ok()) << one.error().message();
  ASSERT_EQ(one->atoms.size(), 1u);
  EXPECT_EQ(one->atoms[0].radius, 1.80);
  EXPECT_EQ(one->atoms[0].center.z, 3.0);
}

TEST(MmcifReader, ReadsTheFirstBlockOfSeveral) {
  // The README's rule, "_atom_site of the first data block": gemmi refused a second block with coordinates.
  const std::string second = "data_u\nloop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n"
                             "_atom_site.label_alt_id\n_atom_site.label_asym_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n"
                             "_atom_site.Cartn_z\n_atom_site.occupancy\n_atom_site.B_iso_or_equiv\n"
                             "_atom_site.auth_seq_id\nATOM 1 O . A 7.0 7.0 7.0 1.0 10 1\nATOM 2 O . A 8.0 7.0 7.0 1.0 10 1\n";
  const result<molecule> mol = parse_mmcif(cif_header + "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10 1 A\n" + second);
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  ASSERT_EQ(mol->atoms.size(), 1u);
  EXPECT_EQ(mol->atoms[0].center.x, 1.0);
}

TEST(MmcifReader, RejectsBadInputNamingTheLineOrAtom) {
  const struct {
    std::string text, message;
  } cases[] = {
      {cif_header + "ATOM 1 N N . GLY A 1 1 abc 2.0 3.0 1.0 10 1 A\n",
       "atom 1 (N GLY A 1): x coordinate is not a finite number"},
      // Every missing column the atoms need is named at once (a sweep find was "no _atom_site row").
      {"data_t\nloop_\n_atom_site.id\n_atom_site.Cartn_x\n1 2.0\n",
       "mmCIF _atom_site has no _atom_site.type_symbol, _atom_site.Cartn_y, _atom_site.Cartn_z, "
       "_atom_site.label_atom_id (or _atom_site.auth_atom_id), _atom_site.label_comp_id (or _atom_site.auth_comp_id) "
       "columns"},
      {"data_t\nloop_\n_atom_site.type_symbol\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.auth_atom_id\n"
       "_atom_site.auth_comp_id\nC 2.0 1.0 CA GLY\n",
       "mmCIF _atom_site has no _atom_site.Cartn_z column"},
      // Coordinates only in a later block: said so (gemmi's text was "2+ blocks are ok if only the first one has
      // coordinates;\x0a_atom_site in block #2: input").
      {"data_first\n_entry.id x\n" + cif_header + "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10 1 A\n",
       "mmCIF: the first data block has no _atom_site, block 2 has: the coordinates are read from the first block"},
      {"data_t\n_x.y 'unterminated\n", "line 2: column 19: mmCIF syntax: unterminated 'string'"},
      // A fuzz find: gemmi throws std::invalid_argument (not a runtime_error) for a sequence number that is not an
      // integer, which ended the process.
      {cif_header + "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10 x1 A\n", "mmCIF: not an integer: x"},
  };
  for (const auto& c : cases) {
    const result<molecule> mol = parse_mmcif(c.text);
    ASSERT_FALSE(mol.ok()) << c.text;
    EXPECT_EQ(mol.error().message(), c.message);
    EXPECT_EQ(mol.error().code(), errc::invalid_input);
  }
  EXPECT_EQ(parse_mmcif("data_t\n_entry.id x\n").error().code(), errc::nothing_to_mesh);
}

// A fuzz find: gemmi's syntax error quotes the input, and a quoted backslash takes 4 characters, so a block name
// of backslashes made a message of 643 characters; gemmi's text now goes in by its escaped length.
TEST(MmcifReader, GemmiMessagesStayOneBoundedLineWhateverTheyQuote) {
  for (const std::string& text : {"data_" + std::string(200, '\\') + "\n_x.y\n",
                                  "data_" + std::string(200, '\\') + "\n_x.y #comment\n",
                                  "data_t\n_x.y '" + std::string(300, '\\') + "\n"}) {
    const result<molecule> mol = parse_mmcif(text);
    ASSERT_FALSE(mol.ok());
    EXPECT_EQ(mol.error().code(), errc::invalid_input);
    EXPECT_LE(mol.error().message().size(), 400u) << mol.error().message();
    EXPECT_TRUE(mol.error().message().rfind("line 2", 0) == 0 || mol.error().message().rfind("mmCIF syntax: ", 0) == 0)
        << mol.error().message();
    EXPECT_EQ(mol.error().message().find_first_of("\n\r"), std::string::npos);
  }
}

// A fuzz find: gemmi reads integer fields into an int without an overflow check (a signed overflow, undefined
// behaviour, that UBSan reported on an 11-digit sequence number). Such values are refused before gemmi reads them;
// the largest values that fit still parse, and other categories (gemmi reads none of _citation) are not looked at.
TEST(MmcifReader, RefusesIntegersBeyondTheIntRangeBeforeGemmiReadsThem) {
  const std::string atom_then = cif_header + "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10 ";
  const struct {
    std::string seq_id, message;
  } refused[] = {
      {"99999999999", "mmCIF _atom_site.auth_seq_id '99999999999' is an integer beyond the 32-bit range"},
      {"2147483648", "mmCIF _atom_site.auth_seq_id '2147483648' is an integer beyond the 32-bit range"},
      {"-2147483649", "mmCIF _atom_site.auth_seq_id '-2147483649' is an integer beyond the 32-bit range"},
      {"'12345678901'", "mmCIF _atom_site.auth_seq_id ''12345678901'' is an integer beyond the 32-bit range"},
  };
  for (const auto& c : refused) {
    const result<molecule> mol = parse_mmcif(atom_then + c.seq_id + " A\n");
    ASSERT_FALSE(mol.ok()) << c.seq_id;
    EXPECT_EQ(mol.error().message(), c.message);
    EXPECT_EQ(mol.error().code(), errc::invalid_input);
  }
  for (const char* fits : {"2147483647", "-2147483648", "000000000000001"}) {
    const result<molecule> mol = parse_mmcif(atom_then + fits + " A\n");
    EXPECT_TRUE(mol.ok()) << fits << ": " << mol.error().message();
  }
  const result<molecule> helix = parse_mmcif(atom_then + "1 A\n_struct_conf.pdbx_PDB_helix_length 9999999999\n");
  ASSERT_FALSE(helix.ok());
  EXPECT_EQ(helix.error().message(),
            "mmCIF _struct_conf.pdbx_PDB_helix_length '9999999999' is an integer beyond the 32-bit range");
  EXPECT_TRUE(parse_mmcif(atom_then + "1 A\n_citation.book_id_ISBN 9780198520078\n").ok());
}

}  // namespace
}  // namespace tracemesh
