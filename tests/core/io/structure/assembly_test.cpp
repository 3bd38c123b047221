// Biological assemblies (issue 35, point 3): the deposited 2BUK entry built as its 60-copy capsid from its REMARK
// 350 BIOMT operators, an mmCIF assembly from _pdbx_struct_assembly_gen / _pdbx_struct_oper_list, and the records
// that would build a wrong assembly refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "core/io/structure/assembly_records.hpp"
#include "core/io/structure/molecule_reader.hpp"
#include "core/io/structure/pdb_mmcif_reader.hpp"
#include "support/test_paths.hpp"

// A namespace of its own: the unity build may put this file beside others with helpers of the same names.
namespace tracemesh::assembly_test {
namespace {

const std::filesystem::path capsid_entry = testing::test_data_path("molecules/2buk.pdb.gz");

structure_options assembly(const std::string& id) {
  structure_options options;
  options.assembly = id;
  return options;
}

/// 2BUK's unit has three calcium ions, which the Bondi set has no radius for: the entry is read with Mantina's.
structure_options capsid_options(const std::string& id) {
  structure_options options = assembly(id);
  options.radii = radii_set::mantina;
  return options;
}

read_molecule_result read_ok(const std::filesystem::path& path, const structure_options& options,
                             const mesh_limits& limits = {}) {
  result<read_molecule_result> read = read_molecule_file(path, options, limits);
  EXPECT_TRUE(read.ok()) << read.error().message();
  return read.ok() ? std::move(*read) : read_molecule_result{};
}

/// `m` x + `t`, the operator as the file gives it (rows of the matrix, then the translation).
vec3 apply(const double (&m)[3][3], const double (&t)[3], const vec3& x) {
  return {m[0][0] * x.x + m[0][1] * x.y + m[0][2] * x.z + t[0], m[1][0] * x.x + m[1][1] * x.y + m[1][2] * x.z + t[1],
          m[2][0] * x.x + m[2][1] * x.y + m[2][2] * x.z + t[2]};
}

void expect_near(const vec3& a, const vec3& b, const std::string& what) {
  EXPECT_NEAR(a.x, b.x, 1e-9) << what;
  EXPECT_NEAR(a.y, b.y, 1e-9) << what;
  EXPECT_NEAR(a.z, b.z, 1e-9) << what;
}

TEST(Assembly, TheCapsidOf2bukIsSixtyCopiesOfItsUnitMovedByTheBiomtOperators) {
  structure_options protein = capsid_options("asu");
  protein.keep_ligands = false;  // the three calcium ions, which lie on symmetry axes: next test
  const read_molecule_result unit = read_ok(capsid_entry, protein);
  // 1,588 atom records: 1,427 protein atoms, 3 calcium ions and 158 waters (dropped by default).
  ASSERT_EQ(unit.mol.atoms.size(), 1427u);
  EXPECT_EQ(unit.assembly, "asu");
  EXPECT_EQ(unit.assembly_operators, 0u);

  protein.assembly = "1";
  const read_molecule_result capsid = read_ok(capsid_entry, protein);
  EXPECT_EQ(capsid.format, input_format::pdb);
  EXPECT_EQ(capsid.assembly, "1");
  EXPECT_EQ(capsid.assembly_operators, 60u);
  const std::size_t n = unit.mol.atoms.size();
  ASSERT_EQ(capsid.mol.atoms.size(), 60 * n);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(capsid.mol.atoms[i].center, unit.mol.atoms[i].center) << "operator 1 is the identity; atom " << i;
  }
  // Operators 2 and 60 as the entry's REMARK 350 BIOMT lines give them.
  const double m2[3][3] = {{0.600223, 0.189076, 0.777164}, {-0.719961, 0.550976, 0.421997},
                           {-0.348409, -0.812820, 0.466836}};
  const double t2[3] = {-6.37893, 33.78484, 50.49749};
  const double m60[3][3] = {{-0.475000, 0.595529, -0.647858}, {-0.262878, 0.606569, 0.750313},
                            {0.839804, 0.526706, -0.131569}};
  const double t60[3] = {139.25557, -15.27565, -9.80131};
  for (const std::size_t i : {std::size_t{0}, n / 2, n - 1}) {
    expect_near(capsid.mol.atoms[n + i].center, apply(m2, t2, unit.mol.atoms[i].center),
                "copy 2, atom " + std::to_string(i));
    expect_near(capsid.mol.atoms[59 * n + i].center, apply(m60, t60, unit.mol.atoms[i].center),
                "copy 60, atom " + std::to_string(i));
    EXPECT_EQ(capsid.mol.atoms[59 * n + i].radius, unit.mol.atoms[i].radius);
  }
}

TEST(Assembly, AnAtomOnASymmetryAxisIsKeptOnce) {
  // Calcium 1196 lies in a general position (60 copies), 1197 on a 3-fold axis (3 copies at each of 20 places),
  // 1198 on the 5-fold axis (5 copies at each of 12 places, 0.007 Å apart at most): 60 + 20 + 12 ions are kept,
  // 88 copies merged.
  const read_molecule_result capsid = read_ok(capsid_entry, capsid_options("1"));
  EXPECT_EQ(capsid.assembly_merged_atoms, 88u);
  ASSERT_EQ(capsid.mol.atoms.size(), 60u * 1430u - 88u);
  const double calcium_radius = 2.31;  // Mantina's; no other element of the entry has it
  std::size_t ions = 0;
  for (const atom& a : capsid.mol.atoms) ions += a.radius == calcium_radius ? 1 : 0;
  EXPECT_EQ(ions, 92u);
  // With the waters kept, those on axes are merged too: the count is of the atoms the options keep.
  structure_options waters = capsid_options("1");
  waters.keep_waters = true;
  const read_molecule_result wet = read_ok(capsid_entry, waters);
  EXPECT_EQ(wet.assembly_merged_atoms, 264u);
  EXPECT_EQ(wet.mol.atoms.size(), 60u * 1588u - 264u);
}

TEST(Assembly, AnIdTheFileDoesNotListIsRefusedListingItsIds) {
  const result<read_molecule_result> unknown = read_molecule_file(capsid_entry, capsid_options("9"));
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code(), errc::invalid_input);
  EXPECT_EQ(unknown.error().message(),
            "assembly '9' is not in the file: its assemblies are 1, or asu (the file's own coordinates)");
}

TEST(Assembly, TheAtomLimitCountsEveryCopyBeforeTheAssemblyIsBuilt) {
  mesh_limits limits;
  limits.max_atoms = 60 * 1430 - 1;  // the unit fits; its 60 copies (waters dropped, ions not yet merged) do not
  EXPECT_TRUE(read_molecule_file(capsid_entry, capsid_options("asu"), limits).ok());
  const result<read_molecule_result> over = read_molecule_file(capsid_entry, capsid_options("1"), limits);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code(), errc::limit_exceeded);
  EXPECT_EQ(over.error().message(),
            "assembly '1' has 85800 atoms (60 operators), more than 85799 (limits.max_atoms)");
}

TEST(Assembly, PqrAndXyzrInputsHaveOnlyTheirOwnAtoms) {
  const std::string pqr = "ATOM      1  CA  GLY A   1       0.000   0.000   0.000  0.0000 1.7000\n";
  const std::string xyzr = "0 0 0 1.7\n";
  for (const auto& [text, name] : {std::pair{pqr, "a PQR"}, std::pair{xyzr, "an xyzr"}}) {
    EXPECT_TRUE(read_molecule(text, assembly("asu"), {}, 1 << 20).ok()) << name;
    const result<read_molecule_result> refused = read_molecule(text, assembly("1"), {}, 1 << 20);
    ASSERT_FALSE(refused.ok()) << name;
    EXPECT_EQ(refused.error().code(), errc::invalid_input);
    EXPECT_EQ(refused.error().message(),
              std::string("assembly '1': ") + name +
                  " file has no symmetry operators (PDB REMARK 350 BIOMT and mmCIF _pdbx_struct_oper_list have); "
                  "only asu (the file's atoms) can be meshed");
  }
}

TEST(Assembly, TheOptionIsAsuOrAPlainId) {
  const auto parse = [](const char* value) {
    return parse_structure_options([value](std::string_view name) -> std::optional<std::string> {
      if (name == "assembly") return std::string(value);
      return std::nullopt;
    });
  };
  EXPECT_EQ(parse_structure_options([](std::string_view) { return std::nullopt; })->assembly, "asu");
  EXPECT_EQ(parse("1")->assembly, "1");
  EXPECT_EQ(parse("PAU")->assembly, "PAU");
  for (const char* bad : {"", "1 2", "a'b", "123456789012345678901234567890123"}) {
    const result<structure_options> refused = parse(bad);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_EQ(refused.error().code(), errc::invalid_argument);
    EXPECT_EQ(refused.error().message().rfind("assembly must be asu or an assembly id of 1 to 32 letters", 0), 0u)
        << refused.error().message();
  }
}

// ---- PDB REMARK 350 -------------------------------------------------------------------------------------------

std::string pdb_atom(int serial, char chain, double x) {
  char line[100];
  std::snprintf(line, sizeof line, "ATOM  %5d  CA  GLY %c%4d    %8.3f%8.3f%8.3f  1.00 10.00           C  \n", serial,
                chain, serial, x, 0.0, 0.0);
  return line;
}

std::string biomt(int row, int serial, double a, double b, double c, double t) {
  char line[100];
  std::snprintf(line, sizeof line, "REMARK 350   BIOMT%d %3d %9.6f %9.6f %9.6f     %10.5f            \n", row, serial,
                a, b, c, t);
  return line;
}

/// Biomolecule 1: chains A and B under the identity and a half turn about z moved 10 Å along x; biomolecule 2:
/// chain B alone, the identity.
std::string two_assemblies() {
  std::string text = "REMARK 350 BIOMOLECULE: 1                                                       \n"
                     "REMARK 350 APPLY THE FOLLOWING TO CHAINS: A, B                                  \n";
  text += biomt(1, 1, 1, 0, 0, 0) + biomt(2, 1, 0, 1, 0, 0) + biomt(3, 1, 0, 0, 1, 0);
  text += biomt(1, 2, -1, 0, 0, 10) + biomt(2, 2, 0, -1, 0, 0) + biomt(3, 2, 0, 0, 1, 0);
  text += "REMARK 350 BIOMOLECULE: 2                                                       \n"
          "REMARK 350 APPLY THE FOLLOWING TO CHAINS: B                                     \n";
  text += biomt(1, 1, 1, 0, 0, 0) + biomt(2, 1, 0, 1, 0, 0) + biomt(3, 1, 0, 0, 1, 0);
  return text + pdb_atom(1, 'A', 1) + pdb_atom(2, 'A', 2) + "TER\n" + pdb_atom(3, 'B', 3);
}

TEST(Assembly, PdbGeneratorsApplyTheirOperatorsToTheirChains) {
  const result<structure_read> one = read_pdb_structure(two_assemblies(), assembly("1"));
  ASSERT_TRUE(one.ok()) << one.error().message();
  EXPECT_EQ(one->assembly_operators, 2u);
  ASSERT_EQ(one->mol.atoms.size(), 6u);
  const double xs[] = {1, 2, 3, 9, 8, 7};  // the identity, then x → 10 − x
  for (std::size_t i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(one->mol.atoms[i].center.x, xs[i]) << i;
  const result<structure_read> two = read_pdb_structure(two_assemblies(), assembly("2"));
  ASSERT_TRUE(two.ok()) << two.error().message();
  ASSERT_EQ(two->mol.atoms.size(), 1u);
  EXPECT_EQ(two->mol.atoms[0].center.x, 3.0);
  const result<structure_read> asu = read_pdb_structure(two_assemblies());
  EXPECT_EQ(asu->mol.atoms.size(), 3u);
  EXPECT_EQ(asu->assembly_operators, 0u);
}

TEST(Assembly, DamagedBiomtRecordsAreRefusedNamingTheLine) {
  const std::string good = two_assemblies();
  const auto damaged = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return text.replace(at, from.size(), to);
  };
  const struct {
    std::string text, message, id = "1";
  } cases[] = {
      {damaged("10.00000", "1O.00000"),
       "line 6: BIOMT translation '1O.00000' (columns 59-68) is not a decimal number"},
      {damaged(" 0.000000 -1.000000", " 0.000000 -1.0x0000"),
       "line 7: BIOMT matrix column 2 '-1.0x0000' (columns 34-43) is not a decimal number"},
      {damaged("BIOMT2   2", "BIOMT3   2"),
       "line 7: BIOMT row '3' (column 19) where row 2 of an operator was expected"},
      {damaged("BIOMT2   2", "BIOMT2   7"), "line 7: BIOMT row 2 of operator '7' follows the rows of operator '2'"},
      {damaged("REMARK 350 APPLY THE FOLLOWING TO CHAINS: A, B", "REMARK 350 APPLY THE FOLLOWING TO CHAIN:  A, B"),
       "line 3: BIOMT operator of biomolecule 1 before its APPLY THE FOLLOWING TO CHAINS line"},
      {damaged(biomt(3, 2, 0, 0, 1, 0), ""), "REMARK 350 biomolecule 1: operator '2' has BIOMT rows 1 to 2 only"},
      // A damaged matrix that reads as numbers: the copy would be sheared, not moved.
      {damaged("BIOMT1   2 -1.000000  0.000000", "BIOMT1   2 -1.000000  0.300000"),
       "assembly '1', operator 2 ('2'): its matrix is not a rotation (its columns are not orthonormal)"},
      {damaged("APPLY THE FOLLOWING TO CHAINS: B   ", "APPLY THE FOLLOWING TO CHAINS: C   "),
       "assembly '2' applies its operators to chains C, which have no atom in the file's first model", "2"},
  };
  for (const auto& c : cases) {
    const result<structure_read> read = read_pdb_structure(c.text, assembly(c.id));
    ASSERT_FALSE(read.ok()) << c.message;
    EXPECT_EQ(read.error().code(), errc::invalid_input);
    EXPECT_EQ(read.error().message(), c.message);
  }
  // The deposited model does not depend on the assembly records: asu reads a file whose REMARK 350 is damaged.
  EXPECT_TRUE(read_pdb_structure(damaged("BIOMT2   2", "BIOMT3   2")).ok());
  const result<structure_read> none = read_pdb_structure(pdb_atom(1, 'A', 1), assembly("1"));
  EXPECT_EQ(none.error().message(),
            "assembly '1': the file lists no assembly (REMARK 350 BIOMOLECULE); only asu (the file's own "
            "coordinates) can be meshed");
}

// ---- mmCIF ----------------------------------------------------------------------------------------------------

/// Three atoms in subchains A (two) and B (one), assembly 1 of both under operators 1 and 2 (a half turn about z
/// moved 10 Å along x), assembly 2 of B under operator 1; operator 3 moves 100 Å along z; `expression` replaces
/// assembly 1's "(1,2)".
std::string mmcif(const std::string& expression = "(1,2)", const std::string& operator_2 = "-1 0 0 10 0 -1 0 0") {
  return "data_test\n"
         "loop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
         "_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.label_seq_id\n_atom_site.Cartn_x\n"
         "_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.auth_asym_id\n"
         "ATOM 1 C CA GLY A 1 1 0 0 A\nATOM 2 C CA GLY A 2 2 0 0 A\nATOM 3 C CA GLY B 1 3 0 0 B\n"
         "loop_\n_pdbx_struct_assembly.id\n_pdbx_struct_assembly.details\n_pdbx_struct_assembly.method_details\n"
         "_pdbx_struct_assembly.oligomeric_details\n_pdbx_struct_assembly.oligomeric_count\n"
         "1 author_defined_assembly ? dimeric 2\n2 author_defined_assembly ? monomeric 1\n"
         "loop_\n_pdbx_struct_assembly_gen.assembly_id\n_pdbx_struct_assembly_gen.oper_expression\n"
         "_pdbx_struct_assembly_gen.asym_id_list\n"
         "1 '" + expression + "' A,B\n2 1 B\n"
         "loop_\n_pdbx_struct_oper_list.id\n_pdbx_struct_oper_list.type\n"
         "_pdbx_struct_oper_list.matrix[1][1]\n_pdbx_struct_oper_list.matrix[1][2]\n"
         "_pdbx_struct_oper_list.matrix[1][3]\n_pdbx_struct_oper_list.vector[1]\n"
         "_pdbx_struct_oper_list.matrix[2][1]\n_pdbx_struct_oper_list.matrix[2][2]\n"
         "_pdbx_struct_oper_list.matrix[2][3]\n_pdbx_struct_oper_list.vector[2]\n"
         "_pdbx_struct_oper_list.matrix[3][1]\n_pdbx_struct_oper_list.matrix[3][2]\n"
         "_pdbx_struct_oper_list.matrix[3][3]\n_pdbx_struct_oper_list.vector[3]\n"
         "1 'identity operation' 1 0 0 0 0 1 0 0 0 0 1 0\n"
         "2 'point symmetry operation' " + operator_2 + " 0 0 1 0\n"
         "3 'transform to point frame' 1 0 0 0 0 1 0 0 0 0 1 100\n";
}

TEST(Assembly, MmcifGeneratorsApplyTheirOperatorsToTheirSubchains) {
  const result<structure_read> one = read_mmcif_structure(mmcif(), assembly("1"));
  ASSERT_TRUE(one.ok()) << one.error().message();
  EXPECT_EQ(one->assembly_operators, 2u);
  ASSERT_EQ(one->mol.atoms.size(), 6u);
  const double xs[] = {1, 2, 3, 9, 8, 7};
  for (std::size_t i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(one->mol.atoms[i].center.x, xs[i]) << i;
  const result<structure_read> two = read_mmcif_structure(mmcif(), assembly("2"));
  ASSERT_TRUE(two.ok()) << two.error().message();
  ASSERT_EQ(two->mol.atoms.size(), 1u);
  EXPECT_EQ(two->mol.atoms[0].center.x, 3.0);
  // A range names the same operators.
  EXPECT_EQ(read_mmcif_structure(mmcif("(1-2)"), assembly("1"))->mol.atoms.size(), 6u);
  // A product applies its groups from right to left: (3)(1,2) is 1 then 3, and 2 then 3 (gemmi alone read (3)).
  const result<structure_read> product = read_mmcif_structure(mmcif("(3)(1,2)"), assembly("1"));
  ASSERT_TRUE(product.ok()) << product.error().message();
  EXPECT_EQ(product->assembly_operators, 2u);
  ASSERT_EQ(product->mol.atoms.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(product->mol.atoms[i].center.x, xs[i]) << i;
    EXPECT_DOUBLE_EQ(product->mol.atoms[i].center.z, 100.0) << i;
  }
  // Through read_molecule: detected as mmCIF, the assembly reported.
  const result<read_molecule_result> read = read_molecule(mmcif(), assembly("1"), {}, 1 << 20);
  ASSERT_TRUE(read.ok()) << read.error().message();
  EXPECT_EQ(read->format, input_format::mmcif);
  EXPECT_EQ(read->assembly_operators, 2u);
  const result<read_molecule_result> unknown = read_molecule(mmcif(), assembly("3"), {}, 1 << 20);
  EXPECT_EQ(unknown.error().message(),
            "assembly '3' is not in the file: its assemblies are 1, 2, or asu (the file's own coordinates)");
}

TEST(Assembly, MmcifExpressionsThatWouldBuildAWrongAssemblyAreRefused) {
  const struct {
    std::string text, message;
  } cases[] = {
      {mmcif("(1)2"),
       "mmCIF _pdbx_struct_assembly_gen.oper_expression '(1)2': text between or after the parenthesised groups"},
      {mmcif("(1,4)"),
       "mmCIF assembly '1': operator '4' of oper_expression '(1,4)' is not in _pdbx_struct_oper_list (with id, "
       "matrix[i][j] and vector[i])"},
      {mmcif("(2-1)"),
       "mmCIF _pdbx_struct_assembly_gen.oper_expression '(2-1)': the range '2-1' is not two numbers, the first not "
       "above the second"},
      {mmcif("(1,2)", "-1 0.5 0 10 0 -1 0 0"),
       "assembly '1', operator 2 ('2'): its matrix is not a rotation (its columns are not orthonormal)"},
      {mmcif("(1,2)", "-1 0 0 ? 0 -1 0 0"), "assembly '1', operator 2 ('2'): its translation is not a number"},
  };
  for (const auto& c : cases) {
    const result<structure_read> read = read_mmcif_structure(c.text, assembly("1"));
    ASSERT_FALSE(read.ok()) << c.message;
    EXPECT_EQ(read.error().code(), errc::invalid_input);
    EXPECT_EQ(read.error().message(), c.message);
    EXPECT_TRUE(read_mmcif_structure(c.text).ok()) << "asu does not build the assembly: " << c.message;
  }
  // gemmi expands every range of every assembly when it reads the file, asu too: a huge one is refused before it
  // (it took minutes and gigabytes), and a bound beyond the int range (a signed overflow in gemmi) as well.
  for (const std::string& id : {std::string("asu"), std::string("1")}) {
    const result<structure_read> huge = read_mmcif_structure(mmcif("(1-2000000000)"), assembly(id));
    ASSERT_FALSE(huge.ok());
    EXPECT_EQ(huge.error().code(), errc::limit_exceeded);
    EXPECT_EQ(huge.error().message(),
              "mmCIF _pdbx_struct_assembly_gen.oper_expression '(1-2000000000)' names more than 2000000 operators "
              "(limits.max_atoms: each copies at least one atom)");
    const result<structure_read> overflow = read_mmcif_structure(mmcif("(1-99999999999)"), assembly(id));
    ASSERT_FALSE(overflow.ok());
    EXPECT_EQ(overflow.error().message(),
              "mmCIF _pdbx_struct_assembly_gen.oper_expression '(1-99999999999)': a range bound beyond the 32-bit "
              "range");
  }
}

TEST(AssemblyRecords, OperatorGroupsOfAnExpression) {
  using groups = std::vector<std::vector<std::string>>;
  const auto parse = [](std::string_view expression) {
    result<groups> parsed = detail::operator_groups(expression, 100);
    EXPECT_TRUE(parsed.ok()) << expression << ": " << parsed.error().message();
    return parsed.ok() ? *parsed : groups{};
  };
  EXPECT_EQ(parse("1"), (groups{{"1"}}));
  EXPECT_EQ(parse("(1)"), (groups{{"1"}}));
  EXPECT_EQ(parse("(1-3)"), (groups{{"1", "2", "3"}}));
  EXPECT_EQ(parse("(1, 3-4,X0)"), (groups{{"1", "3", "4", "X0"}}));
  EXPECT_EQ(parse("(X0)(1-3)"), (groups{{"X0"}, {"1", "2", "3"}}));
  EXPECT_EQ(parse(" (1,2) (3) "), (groups{{"1", "2"}, {"3"}}));
  EXPECT_EQ(detail::operator_groups("(1-101)", 100).error().code(), errc::limit_exceeded);
  EXPECT_EQ(detail::operator_groups("(1-10)(1-11)", 100).error().code(), errc::limit_exceeded) << "110 operators";
  EXPECT_TRUE(detail::operator_groups("(1-10)(1-10)", 100).ok());
  EXPECT_EQ(detail::operator_groups("(1,,2)", 100).error().code(), errc::invalid_input);
  EXPECT_EQ(detail::operator_groups("(1-2", 100).error().code(), errc::invalid_input);
  EXPECT_EQ(detail::operator_groups("(1)x(2)", 100).error().code(), errc::invalid_input);
  EXPECT_EQ(*detail::gemmi_operator_id_count("(1-60)(61-88)", 100), 60u) << "gemmi reads the first factor";
  EXPECT_EQ(*detail::gemmi_operator_id_count("1,2,5-9", 100), 7u);
  EXPECT_EQ(detail::gemmi_operator_id_count("(2147483646-2147483647)", 100).error().code(), errc::invalid_input)
      << "gemmi's ++ past the int maximum";
}

}  // namespace
}  // namespace tracemesh::assembly_test
