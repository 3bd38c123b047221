// A PQR file whose first atom line is damaged is still PQR (its reader names the damaged lines), never a PDB file
// read with table radii; a declared format takes precedence over detection and a contradicted one is refused.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/io/structure/molecule_reader.hpp"
#include "support/structure_writers.hpp"
#include "support/test_paths.hpp"

namespace tracemesh::declared_format_test {

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t begin = 0;
  while (begin < text.size()) {
    const std::size_t end = text.find('\n', begin);
    lines.push_back(text.substr(begin, end - begin));
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  return lines;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

/// `line` with its last whitespace-separated field (the radius of a PQR record) replaced by `radius`; an empty
/// `radius` removes the field.
std::string with_radius(const std::string& line, const std::string& radius) {
  const std::size_t last = line.find_last_of(" \t");
  return radius.empty() ? line.substr(0, last) : line.substr(0, last + 1) + radius;
}

result<read_molecule_result> read(const std::string& text, const structure_options& options = {}) {
  return read_molecule(text, options, mesh_limits{}, 1 << 26);
}

structure_options declaring(input_format format, const std::string& by) {
  structure_options options;
  options.format = declared_format{format, by};
  return options;
}

class DamagedPqr : public ::testing::Test {
 protected:
  const std::vector<std::string> lines_ = split_lines(read_text(testing::molecule_path("fas2.pqr")));
};

TEST_F(DamagedPqr, AnUnreadableFirstRadiusIsAnErrorNamingTheLineNotAPdbFile) {
  ASSERT_TRUE(lines_.front().starts_with("ATOM")) << "the first line of fas2.pqr is its first atom record";
  for (const std::string damage : {"*****", "nan", "inf", "radius", ""}) {
    std::vector<std::string> damaged = lines_;
    damaged.front() = with_radius(damaged.front(), damage);
    const result<read_molecule_result> molecule = read(join_lines(damaged));
    ASSERT_FALSE(molecule.ok()) << "radius '" << damage << "' on line 1 was read as "
                                << input_format_name(molecule->format) << " with radii " << molecule->radii;
    EXPECT_EQ(molecule.error().code(), errc::invalid_input);
    EXPECT_TRUE(molecule.error().message().starts_with("line 1: ")) << molecule.error().message();
  }
}

TEST_F(DamagedPqr, TheErrorNamesEveryDamagedLineUpToFiveAndCountsThem) {
  std::vector<std::string> damaged = lines_;
  for (const std::size_t line : {1, 2, 40, 41, 300, 301, 302}) damaged[line - 1] = with_radius(damaged[line - 1], "*****");
  const result<read_molecule_result> molecule = read(join_lines(damaged));
  ASSERT_FALSE(molecule.ok());
  EXPECT_EQ(molecule.error().message(),
            "line 1: radius '*****' is not a decimal number (records end with x y z charge radius); 7 of 906 atom "
            "records cannot be read as PQR (lines 1, 2, 40, 41, 300, ...)");
}

TEST_F(DamagedPqr, ADamagedFirstLineDeclaredPqrIsTheSameError) {
  std::vector<std::string> damaged = lines_;
  damaged.front() = with_radius(damaged.front(), "*****");
  const result<read_molecule_result> molecule = read(join_lines(damaged), declaring(input_format::pqr, "test"));
  ASSERT_FALSE(molecule.ok());
  EXPECT_TRUE(molecule.error().message().starts_with("line 1: radius '*****'")) << molecule.error().message();
}

TEST(DeclaredFormat, ReportsTheFormatReadAndWhereTheRadiiCameFrom) {
  const std::string pqr = read_text(testing::molecule_path("gly.pqr"));
  const result<read_molecule_result> from_pqr = read(pqr);
  ASSERT_TRUE(from_pqr.ok()) << from_pqr.error().message();
  EXPECT_EQ(from_pqr->format, input_format::pqr);
  EXPECT_EQ(from_pqr->radii, "file");
  const auto atoms = testing::atoms_of_pqr(pqr);
  structure_options mantina;
  mantina.radii = radii_set::mantina;
  const result<read_molecule_result> from_pdb = read(testing::to_pdb(atoms), mantina);
  ASSERT_TRUE(from_pdb.ok()) << from_pdb.error().message();
  EXPECT_EQ(from_pdb->format, input_format::pdb);
  EXPECT_EQ(from_pdb->radii, "mantina");
  const result<read_molecule_result> from_xyzr = read(testing::to_xyzr(atoms, radii_set::bondi));
  ASSERT_TRUE(from_xyzr.ok());
  EXPECT_EQ(from_xyzr->radii, "file");
}

TEST(DeclaredFormat, DecidesTheAmbiguousCase) {
  // A PDB record without element symbols ends with five numbers (occupancy, B-factor): detected as PQR, its
  // B-factor taken for a radius; declared PDB, its radius comes from the element of its atom name.
  const std::string record = "ATOM      1  CA  GLY A   1      -8.901   4.127  -0.555  1.00  7.73\n";
  const result<read_molecule_result> detected = read(record);
  ASSERT_TRUE(detected.ok()) << detected.error().message();
  EXPECT_EQ(detected->format, input_format::pqr);
  EXPECT_EQ(detected->mol.atoms.front().radius, 7.73);
  const result<read_molecule_result> declared = read(record, declaring(input_format::pdb, "format_in=pdb"));
  ASSERT_TRUE(declared.ok()) << declared.error().message();
  EXPECT_EQ(declared->format, input_format::pdb);
  EXPECT_EQ(declared->radii, "bondi");
  EXPECT_EQ(declared->mol.atoms.front().radius, 1.70);
}

TEST(DeclaredFormat, RefusesADeclarationTheContentContradicts) {
  const auto atoms = testing::atoms_of_pqr(read_text(testing::molecule_path("gly.pqr")));
  const std::string pqr = testing::to_pqr(atoms, radii_set::bondi);
  const std::string pdb = testing::to_pdb(atoms);
  const std::string cif = testing::to_mmcif(atoms);
  const std::string xyzr = testing::to_xyzr(atoms, radii_set::bondi);
  const struct {
    std::string text;
    input_format declared;
    std::string message;
  } cases[] = {
      {cif, input_format::pqr, "the field declares pqr, but the text is mmCIF (it starts with a data_ block)"},
      {cif, input_format::pdb, "the field declares pdb, but the text is mmCIF (it starts with a data_ block)"},
      {pqr, input_format::mmcif, "the field declares mmcif, but the text is not mmCIF (it does not start with a data_ "
                                 "block)"},
      {pqr, input_format::xyzr, "the field declares xyzr, but the text has ATOM/HETATM records (PQR or PDB), not x y "
                                "z r lines"},
      {xyzr, input_format::pqr, "the field declares pqr, but the text is xyzr (x y z r lines, no ATOM/HETATM record)"},
      {xyzr, input_format::pdb, "the field declares pdb, but the text is xyzr (x y z r lines, no ATOM/HETATM record)"},
  };
  for (const auto& c : cases) {
    const result<read_molecule_result> molecule = read(c.text, declaring(c.declared, "the field"));
    ASSERT_FALSE(molecule.ok()) << c.message;
    EXPECT_EQ(molecule.error().code(), errc::invalid_input);
    EXPECT_EQ(molecule.error().message(), c.message);
  }
  // PDB records declared PQR: the PQR reader names them, whatever header comes first.
  for (const std::string& text : {pdb, pdb.substr(pdb.find("ATOM"))}) {
    const result<read_molecule_result> molecule = read(text, declaring(input_format::pqr, "the field"));
    ASSERT_FALSE(molecule.ok());
    EXPECT_EQ(molecule.error().code(), errc::invalid_input);
    EXPECT_TRUE(molecule.error().message().ends_with("7 of 7 atom records cannot be read as PQR (lines " +
                                                     std::string(text == pdb ? "2, 3, 4, 5, 6, ...)" : "1, 2, 3, 4, 5, ...)")))
        << molecule.error().message();
  }
  // Each format declared as itself reads.
  for (const auto& [text, format] : {std::pair{pqr, input_format::pqr}, std::pair{pdb, input_format::pdb},
                                     std::pair{cif, input_format::mmcif}, std::pair{xyzr, input_format::xyzr}}) {
    const result<read_molecule_result> molecule = read(text, declaring(format, "the field"));
    ASSERT_TRUE(molecule.ok()) << input_format_name(format) << ": " << molecule.error().message();
    EXPECT_EQ(molecule->format, format);
    EXPECT_EQ(molecule->mol.atoms.size(), 7u);
  }
}

}  // namespace tracemesh::declared_format_test
