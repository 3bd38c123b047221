#include "core/io/pqr_reader.hpp"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <locale>
#include <string>
#include <vector>

#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

using testing::molecule_path;
using testing::test_data_path;

const std::string glycine_line = "ATOM   8535  N   GLY   561     -10.573  -2.505  35.427 -0.416 1.824";

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << "cannot read fixture " << path;
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// An atom record with the given five trailing fields.
std::string record(const std::string& x, const std::string& y, const std::string& z, const std::string& charge,
                   const std::string& radius) {
  return "ATOM      1  CA  GLY     1    " + x + " " + y + " " + z + " " + charge + " " + radius;
}

molecule parse_ok(std::string_view text, const mesh_limits& limits = {}) {
  result<molecule> parsed = parse_pqr(text, limits);
  EXPECT_TRUE(parsed.ok()) << parsed.error().message();
  return parsed.ok() ? std::move(parsed).value() : molecule{};
}

status parse_error(std::string_view text, const mesh_limits& limits = {}) {
  result<molecule> parsed = parse_pqr(text, limits);
  EXPECT_FALSE(parsed.ok()) << "parsed " << parsed->atoms.size() << " atoms from input that should fail";
  return parsed.error();
}

bool starts_with(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

void expect_atom(const atom& a, double x, double y, double z, double charge, double radius) {
  EXPECT_EQ(a.center.x, x);
  EXPECT_EQ(a.center.y, y);
  EXPECT_EQ(a.center.z, z);
  EXPECT_EQ(a.charge, charge);
  EXPECT_EQ(a.radius, radius);
}

// ---- records and fields ------------------------------------------------------------------------------------

TEST(PqrReader, ReadsTheLastFiveFieldsOfAnAtomRecord) {
  const molecule mol = parse_ok(glycine_line + "\n");
  ASSERT_EQ(mol.atoms.size(), 1u);
  expect_atom(mol.atoms[0], -10.573, -2.505, 35.427, -0.416, 1.824);
  EXPECT_EQ(mol.zero_radius_atoms, 0u);
}

TEST(PqrReader, RecordsWithAndWithoutChainIdReadTheSame) {
  const molecule with_chain = parse_ok("ATOM      1  N   GLY A   1      1.5  -2.25  3.0  -0.5  1.75\n");
  const molecule without_chain = parse_ok("ATOM      1  N   GLY   1      1.5  -2.25  3.0  -0.5  1.75\n");
  ASSERT_EQ(with_chain.atoms.size(), 1u);
  ASSERT_EQ(without_chain.atoms.size(), 1u);
  expect_atom(with_chain.atoms[0], 1.5, -2.25, 3.0, -0.5, 1.75);
  expect_atom(without_chain.atoms[0], 1.5, -2.25, 3.0, -0.5, 1.75);
}

TEST(PqrReader, AcceptsTabsAsFieldSeparators) {
  const molecule mol = parse_ok("ATOM\t1\tN\tGLY\t1\t1.0\t2.0\t3.0\t0.5\t1.5\t\n");
  ASSERT_EQ(mol.atoms.size(), 1u);
  expect_atom(mol.atoms[0], 1.0, 2.0, 3.0, 0.5, 1.5);
}

TEST(PqrReader, ReadsHetatmAndSerialsFusedToTheRecordName) {
  const molecule mol = parse_ok(
      "HETATM    1  PB  ADP     1      44.669   2.928  38.556  -0.0068  1.800\n"
      "HETATM1234  O1B ADP     1      1.0 2.0 3.0 0.1 1.5\n"
      "ATOM  12345  CA  GLY     1      4.0 5.0 6.0 0.2 1.6\n"
      "ATOM100000  CA  GLY     1      7.0 8.0 9.0 0.3 1.7\n"
      "ATOM   1082160 HZ3  LYS    395  -194.630    91.387   -15.469   0.3374  0.6000\n");
  ASSERT_EQ(mol.atoms.size(), 5u);
  expect_atom(mol.atoms[0], 44.669, 2.928, 38.556, -0.0068, 1.8);
  expect_atom(mol.atoms[1], 1.0, 2.0, 3.0, 0.1, 1.5);
  expect_atom(mol.atoms[2], 4.0, 5.0, 6.0, 0.2, 1.6);
  expect_atom(mol.atoms[3], 7.0, 8.0, 9.0, 0.3, 1.7);
  expect_atom(mol.atoms[4], -194.630, 91.387, -15.469, 0.3374, 0.6);
}

TEST(PqrReader, SkipsEveryOtherRecord) {
  const molecule mol = parse_ok(
      "REMARK   1 ATOM 1 N GLY 1 9 9 9 9 9\n"
      "CRYST1   10.000   10.000   10.000  90.00  90.00  90.00 P 1           1\n"
      "MODEL        1\n" +
      glycine_line +
      "\n"
      "TER\n"
      "ENDMDL\n"
      "ATOMS  this is not an atom record 1 2 3 4 5\n"
      "HETATMX not one either 1 2 3 4 5\n"
      " ATOM  1  N GLY 1 1 2 3 4 5\n"
      "atom   1  N GLY 1 1 2 3 4 5\n"
      "ANISOU 1  N GLY 1 1 2 3 4 5 6\n"
      "\n"
      "END\n");
  ASSERT_EQ(mol.atoms.size(), 1u);
  expect_atom(mol.atoms[0], -10.573, -2.505, 35.427, -0.416, 1.824);
}

TEST(PqrReader, RejectsRecordsWithFewerThanFiveNumbers) {
  const status four_fields = parse_error(glycine_line + "\nATOM 1.0 2.0 3.0 1.5\n");
  EXPECT_EQ(four_fields.code(), errc::invalid_input);
  EXPECT_EQ(four_fields.message(),
            "line 2: ATOM record has 5 fields; a PQR atom record has 10 fields (ATOM serial name resName resSeq x y "
            "z charge radius) or 11 (a chain id before resSeq)");

  const status bare_name = parse_error("HETATM\n");
  EXPECT_EQ(bare_name.code(), errc::invalid_input);
  EXPECT_TRUE(starts_with(bare_name.message(), "line 1: HETATM record has 1 fields")) << bare_name.message();
}

// Issue 12, finding 8: a record with a column missing was read with its columns shifted (a wrong mesh, 200).
TEST(PqrReader, RejectsAMissingColumnInsteadOfShiftingTheOthers) {
  struct shifted_case {
    const char* what;
    std::string line;
    std::string message_start;
  };
  const std::vector<shifted_case> cases = {
      {"no chain id, z missing (9 fields)", "ATOM 1 N GLY 1 1.0 2.0 0.5 1.5", "line 2: ATOM record has 9 fields"},
      {"no chain id, charge missing", "ATOM 1 N GLY 1 1.0 2.0 3.0 1.5", "line 2: ATOM record has 9 fields"},
      {"no chain id, residue name missing", "ATOM 1 N 1 1.0 2.0 3.0 0.5 1.5", "line 2: ATOM record has 9 fields"},
      {"chain id, z missing (10 fields, 'A' before x)", "ATOM 1 N GLY A 1 1.0 2.0 0.5 1.5",
       "line 2: residue number 'A' is not an integer: a column is missing or extra"},
      {"chain id, radius missing", "HETATM 1 N GLY B 7 1.0 2.0 3.0 0.5", "line 2: residue number 'B' is not"},
      {"chain id, residue number missing", "ATOM 1 N GLY A 1.0 2.0 3.0 0.5 1.5",
       "line 2: residue number 'A' is not"},
      {"no chain id, one number extra (11 fields, x before x)", "ATOM 1 N GLY 1 1.0 2.0 3.0 4.0 0.5 1.5",
       "line 2: residue number '1.0' is not"},
      {"chain id, one column extra (12 fields)", "ATOM 1 N GLY A 1 1.0 2.0 3.0 4.0 0.5 1.5",
       "line 2: ATOM record has 12 fields"},
      {"tabs, z missing", "ATOM\t1\tN\tGLY\t1\t1.0\t2.0\t0.5\t1.5", "line 2: ATOM record has 9 fields"},
  };
  for (const shifted_case& c : cases) {
    const status error = parse_error(glycine_line + "\n" + c.line + "\n" + glycine_line + "\n");
    EXPECT_EQ(error.code(), errc::invalid_input) << c.what;
    EXPECT_TRUE(starts_with(error.message(), c.message_start)) << c.what << ": " << error.message();
  }
}

TEST(PqrReader, AcceptsResidueNumbersWithSignsInsertionCodesAndFusedChainIds) {
  const molecule mol = parse_ok(
      "ATOM      1  N   GLY A  -3      1.0 2.0 3.0 0.5 1.5\n"
      "ATOM      2  N   GLY A  52A     1.0 2.0 3.0 0.5 1.5\n"
      "ATOM      3  N   GLY   52B     1.0 2.0 3.0 0.5 1.5\n"
      "ATOM      4  N   GLY A1000     1.0 2.0 3.0 0.5 1.5\n"
      "ATOM      5  N   GLY 1 7     1.0 2.0 3.0 0.5 1.5\n");
  EXPECT_EQ(mol.atoms.size(), 5u);
  // A chain id fused to the residue number only makes sense without a separate chain id.
  const status fused_and_chain = parse_error("ATOM      4  N   GLY A B1000     1.0 2.0 3.0 0.5 1.5\n");
  EXPECT_TRUE(starts_with(fused_and_chain.message(), "line 1: residue number 'B1000' is not")) << fused_and_chain.message();
}

// ---- fused fields (PDB fixed-column style) ----------------------------------------------------------------

TEST(PqrReader, SplitsFusedFieldsAtAMinusThatFollowsADigit) {
  const molecule mol = parse_ok(
      "ATOM      1  N   GLY A   1     -12.345-67.890  35.427 -0.416 1.824\n"
      "ATOM      2  N   GLY A1000     -12.345-67.890-35.427 -0.416 1.824\n"
      "ATOM      3  N   GLY A 561-10.573  -2.505  35.427 -0.416 1.824\n"
      "ATOM      4  N   GLY A   1      1.0e-5 -2.0E-3 3.5e+1 -1e-1 1.5\n");
  ASSERT_EQ(mol.atoms.size(), 4u);
  expect_atom(mol.atoms[0], -12.345, -67.890, 35.427, -0.416, 1.824);
  expect_atom(mol.atoms[1], -12.345, -67.890, -35.427, -0.416, 1.824);
  expect_atom(mol.atoms[2], -10.573, -2.505, 35.427, -0.416, 1.824);
  expect_atom(mol.atoms[3], 1.0e-5, -2.0e-3, 35.0, -0.1, 1.5);
}

TEST(PqrReader, RejectsFusedFieldsTheRuleCannotSplit) {
  const status positive = parse_error("ATOM 1 N GLY 1   12.345678.901  35.427 -0.416 1.824\n");
  EXPECT_EQ(positive.code(), errc::invalid_input);
  EXPECT_TRUE(starts_with(positive.message(), "line 1: y coordinate '12.345678.901' is not a decimal number"))
      << positive.message();

  const status charge_radius = parse_error("ATOM 1 N GLY 1 1.0 2.0 3.0 -0.4161.824\n");
  EXPECT_EQ(charge_radius.code(), errc::invalid_input);
  EXPECT_TRUE(starts_with(charge_radius.message(), "line 1: radius '-0.4161.824' is not a decimal number"))
      << charge_radius.message();

  const status dangling_minus = parse_error("ATOM 1 N GLY 1 1.0 2.0 3.0 0.5 1.5-\n");
  EXPECT_EQ(dangling_minus.code(), errc::invalid_input);
  EXPECT_TRUE(starts_with(dangling_minus.message(), "line 1: radius '-' is not a decimal number"))
      << dangling_minus.message();
}

// ---- numbers -------------------------------------------------------------------------------------------------

struct bad_number_case {
  std::string text;
  std::string problem;  ///< expected end of the message
};

class PqrReaderBadNumber : public ::testing::TestWithParam<bad_number_case> {};

TEST_P(PqrReaderBadNumber, IsRejectedInEveryFieldWithTheLineAndFieldNamed) {
  const bad_number_case& bad = GetParam();
  const std::vector<std::string> field_names = {"x coordinate", "y coordinate", "z coordinate", "charge", "radius"};
  for (std::size_t field = 0; field < field_names.size(); ++field) {
    std::vector<std::string> fields = {"1.0", "2.0", "3.0", "0.5", "1.5"};
    fields[field] = bad.text;
    const std::string text =
        glycine_line + "\n" + record(fields[0], fields[1], fields[2], fields[3], fields[4]) + "\n" + glycine_line;
    const status error = parse_error(text);
    EXPECT_EQ(error.code(), errc::invalid_input);
    const std::string expected_start = "line 2: " + field_names[field] + " '" + bad.text + "' " + bad.problem;
    EXPECT_TRUE(starts_with(error.message(), expected_start))
        << "got: " << error.message() << "\nexpected start: " << expected_start;
  }
}

INSTANTIATE_TEST_SUITE_P(
    NotFiniteOutOfRangeOrNotDecimal, PqrReaderBadNumber,
    ::testing::Values(bad_number_case{"nan", "is not finite"}, bad_number_case{"NaN", "is not finite"},
                      bad_number_case{"-nan", "is not finite"}, bad_number_case{"inf", "is not finite"},
                      bad_number_case{"-inf", "is not finite"}, bad_number_case{"Infinity", "is not finite"},
                      bad_number_case{"1e400", "is out of the range of a double"},
                      bad_number_case{"-1e400", "is out of the range of a double"},
                      bad_number_case{"1e-400", "is out of the range of a double"},
                      bad_number_case{"0x1p3", "is not a decimal number"},
                      bad_number_case{"1,5", "is not a decimal number"},
                      bad_number_case{"1.5abc", "is not a decimal number"},
                      bad_number_case{"1.5e", "is not a decimal number"},
                      bad_number_case{"--1", "is not a decimal number"},
                      bad_number_case{"+-1", "is not a decimal number"},
                      bad_number_case{"++1", "is not a decimal number"},
                      bad_number_case{"abc", "is not a decimal number"}));

TEST(PqrReader, AcceptsALeadingPlusSign) {
  const molecule mol = parse_ok(record("+1.0", "+.5", "3", "+0.25", "+1.5"));
  ASSERT_EQ(mol.atoms.size(), 1u);
  expect_atom(mol.atoms[0], 1.0, 0.5, 3.0, 0.25, 1.5);
}

TEST(PqrReader, IgnoresTheGlobalLocale) {
  struct comma_decimal : std::numpunct<char> {
    char do_decimal_point() const override { return ','; }
  };
  const std::locale previous = std::locale::global(std::locale(std::locale::classic(), new comma_decimal));
  const result<molecule> parsed = parse_pqr(record("1.5", "2.25", "3.125", "-0.5", "1.75"));
  const result<molecule> comma = parse_pqr(record("1,5", "2.25", "3.125", "-0.5", "1.75"));
  std::locale::global(previous);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message();
  expect_atom(parsed->atoms[0], 1.5, 2.25, 3.125, -0.5, 1.75);
  EXPECT_EQ(comma.error().code(), errc::invalid_input);
}

// ---- value ranges --------------------------------------------------------------------------------------------

TEST(PqrReader, RejectsCoordinatesBeyondTheLimit) {
  mesh_limits limits;
  limits.max_abs_coordinate = 500;
  const molecule at_limit = parse_ok(record("500", "-500", "0", "0", "1"), limits);
  ASSERT_EQ(at_limit.atoms.size(), 1u);

  const status x_over = parse_error(record("500.001", "0", "0", "0", "1"), limits);
  EXPECT_EQ(x_over.code(), errc::invalid_input);
  EXPECT_EQ(x_over.message(), "line 1: x coordinate 500.001 is beyond +-500 Angstrom (limits.max_abs_coordinate)");

  const status z_over = parse_error(glycine_line + "\n" + record("0", "0", "-1e9", "0", "1"));
  EXPECT_EQ(z_over.code(), errc::invalid_input);
  EXPECT_TRUE(starts_with(z_over.message(), "line 2: z coordinate -1e9 is beyond")) << z_over.message();
}

TEST(PqrReader, RejectsNegativeRadiiIncludingNegativeZero) {
  const std::string text = "REMARK\n" + std::string(10, '\n') + record("1", "2", "3", "0", "-1.5");
  const status negative = parse_error(text);
  EXPECT_EQ(negative.code(), errc::invalid_input);
  EXPECT_EQ(negative.message(), "line 12: radius -1.5 is negative");

  const status negative_zero = parse_error(record("1", "2", "3", "0", "-0.0"));
  EXPECT_EQ(negative_zero.code(), errc::invalid_input);
  EXPECT_EQ(negative_zero.message(), "line 1: radius -0.0 is negative");
}

TEST(PqrReader, RejectsRadiiAboveTheLimit) {
  mesh_limits limits;
  limits.max_radius = 3;
  EXPECT_EQ(parse_ok(record("0", "0", "0", "0", "3.0"), limits).atoms.size(), 1u);
  const status too_large = parse_error(record("0", "0", "0", "0", "3.01"), limits);
  EXPECT_EQ(too_large.code(), errc::invalid_input);
  EXPECT_EQ(too_large.message(), "line 1: radius 3.01 is larger than 3 Angstrom (limits.max_radius)");
  EXPECT_EQ(parse_error(record("0", "0", "0", "0", "10.5")).code(), errc::invalid_input);  // default limit 10
}

TEST(PqrReader, AcceptsAndCountsZeroRadii) {
  const molecule mol = parse_ok(record("0", "0", "0", "0.4", "0") + "\n" + record("1", "0", "0", "0", "1.5") +
                                "\n" + record("2", "0", "0", "0", "0.0"));
  ASSERT_EQ(mol.atoms.size(), 3u);
  EXPECT_EQ(mol.zero_radius_atoms, 2u);
  EXPECT_EQ(mol.atoms[0].radius, 0.0);
  EXPECT_EQ(mol.atoms[0].charge, 0.4);
}

// ---- nothing to mesh, atom limit ------------------------------------------------------------------------------

TEST(PqrReader, ReportsNothingToMeshWithoutAtomsWithRadius) {
  for (const std::string& text : {std::string(), std::string("\n\n"), std::string("REMARK 1 nothing\nTER\nEND\n"),
                                  std::string("\xEF\xBB\xBF")}) {
    const status error = parse_error(text);
    EXPECT_EQ(error.code(), errc::nothing_to_mesh);
    EXPECT_TRUE(starts_with(error.message(), "no atoms with radius > 0")) << error.message();
  }
  const status all_zero = parse_error(record("0", "0", "0", "0", "0") + "\n" + record("1", "1", "1", "0", "0"));
  EXPECT_EQ(all_zero.code(), errc::nothing_to_mesh);
  EXPECT_EQ(all_zero.message(), "no atoms with radius > 0: all 2 atoms have radius 0");
}

TEST(PqrReader, StopsAtTheFirstAtomBeyondMaxAtoms) {
  mesh_limits limits;
  limits.max_atoms = 3;
  const std::string three = glycine_line + "\n" + glycine_line + "\nREMARK\n" + glycine_line + "\n";
  EXPECT_EQ(parse_ok(three, limits).atoms.size(), 3u);
  // The malformed line after the fourth atom is never read: the limit is reported, not the bad line.
  const status error = parse_error(three + glycine_line + "\nATOM garbage\n", limits);
  EXPECT_EQ(error.code(), errc::limit_exceeded);
  EXPECT_EQ(error.message(), "line 5: more than 3 atoms (limits.max_atoms)");
}

// ---- text encoding and line structure -------------------------------------------------------------------------

TEST(PqrReader, AcceptsLfCrlfBareCrAndNoFinalNewline) {
  const std::string a = record("1", "0", "0", "0", "1");
  const std::string b = record("2", "0", "0", "0", "1");
  const std::string c = record("3", "0", "0", "0", "1");
  for (const std::string& text : {a + "\n" + b + "\n" + c + "\n", a + "\r\n" + b + "\r\n" + c + "\r\n",
                                  a + "\r" + b + "\r" + c + "\r", a + "\r\n" + b + "\n" + c}) {
    const molecule mol = parse_ok(text);
    ASSERT_EQ(mol.atoms.size(), 3u);
    EXPECT_EQ(mol.atoms[0].center.x, 1.0);
    EXPECT_EQ(mol.atoms[2].center.x, 3.0);
    EXPECT_EQ(mol.atoms[2].radius, 1.0);
  }
}

TEST(PqrReader, CountsLinesTheSameWithEveryLineEnding) {
  const std::string bad = record("1", "2", "3", "0", "-1");
  for (const std::string ending : {"\n", "\r\n", "\r"}) {
    const std::string text = "REMARK" + ending + ending + glycine_line + ending + bad + ending;
    EXPECT_EQ(parse_error(text).message(), "line 4: radius -1 is negative") << "ending " << ending.size();
  }
}

TEST(PqrReader, SkipsAUtf8ByteOrderMarkAtTheStart) {
  const molecule mol = parse_ok("\xEF\xBB\xBF" + glycine_line + "\n");
  ASSERT_EQ(mol.atoms.size(), 1u);
  expect_atom(mol.atoms[0], -10.573, -2.505, 35.427, -0.416, 1.824);
}

TEST(PqrReader, RejectsUtf16Input) {
  const std::string utf16_le("\xFF\xFE" "A\0T\0O\0M\0", 10);
  const std::string utf16_be("\xFE\xFF" "\0A\0T\0O\0M", 10);
  for (const std::string& text : {utf16_le, utf16_be}) {
    const status error = parse_error(text);
    EXPECT_EQ(error.code(), errc::invalid_input);
    EXPECT_EQ(error.message(), "line 1: UTF-16 byte order mark: PQR must be ASCII or UTF-8 text");
  }
  const status without_bom = parse_error(std::string("A\0T\0O\0M\0 \0", 10));
  EXPECT_EQ(without_bom.code(), errc::invalid_input);
  EXPECT_TRUE(starts_with(without_bom.message(), "line 1: control byte 0x00 at column 2")) << without_bom.message();
}

TEST(PqrReader, RejectsNulAndControlBytesNamingLineAndColumn) {
  std::string with_nul = glycine_line + "\n" + glycine_line + "\n" + glycine_line + "\n";
  with_nul[2 * (glycine_line.size() + 1) + 4] = '\0';
  const status nul = parse_error(with_nul);
  EXPECT_EQ(nul.code(), errc::invalid_input);
  EXPECT_EQ(nul.message(), "line 3: control byte 0x00 at column 5 (binary data, not PQR text)");

  for (const char control : {'\x01', '\x0b', '\x0c', '\x1a', '\x1b', '\x7f'}) {
    const status error = parse_error("REMARK " + std::string(1, control) + "\n" + glycine_line);
    EXPECT_EQ(error.code(), errc::invalid_input);
    EXPECT_TRUE(starts_with(error.message(), "line 1: control byte 0x")) << error.message();
  }
}

TEST(PqrReader, RejectsBinaryGarbage) {
  std::uint64_t state = 0x9E3779B97F4A7C15ULL;  // fixed seed: the same bytes every run
  for (int trial = 0; trial < 50; ++trial) {
    std::string bytes(4096, '\0');
    for (char& byte : bytes) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      byte = static_cast<char>(state >> 56);
    }
    const status error = parse_error(glycine_line + "\n" + bytes);
    EXPECT_EQ(error.code(), errc::invalid_input);
    EXPECT_TRUE(starts_with(error.message(), "line ")) << error.message();
    EXPECT_EQ(error.message().find('\n'), std::string::npos);
  }
}

TEST(PqrReader, AcceptsUtf8TextButRejectsInvalidUtf8) {
  const molecule mol = parse_ok("REMARK   Ångström, 氨基酸 😀\n" + glycine_line);
  EXPECT_EQ(mol.atoms.size(), 1u);
  for (const std::string bad : {"\xFF", "\xC0\xAF", "\xED\xA0\x80", "\xF4\x90\x80\x80", "\xE2\x82", "\x80"}) {
    const status error = parse_error(glycine_line + "\nREMARK ab" + bad + "\n");
    EXPECT_EQ(error.code(), errc::invalid_input);
    EXPECT_TRUE(starts_with(error.message(), "line 2: byte 0x")) << error.message();
    EXPECT_NE(error.message().find("at column 10 is not UTF-8"), std::string::npos) << error.message();
  }
}

TEST(PqrReader, LinesUpToMaxLineBytesAreAccepted) {
  mesh_limits limits;
  limits.max_line_bytes = 100;
  std::string line = record("1", "2", "3", "0", "1");
  line.insert(4, 100 - line.size(), ' ');
  ASSERT_EQ(line.size(), 100u);
  EXPECT_EQ(parse_ok(line + "\r\n" + line, limits).atoms.size(), 2u);

  const status error = parse_error(line + "\n " + line, limits);
  EXPECT_EQ(error.code(), errc::invalid_input);
  EXPECT_EQ(error.message(), "line 2: longer than 100 bytes (limits.max_line_bytes)");
}

TEST(PqrReader, ATenMegabyteLineFailsAfterItsLimitIsPassed) {
  // Only max_line_bytes + 1 bytes of the long line are looked at: a NUL byte further on, which would make the
  // input binary if it were read, is never reached, so the error is the line's length.
  std::string tail(10'000'000, 'A');
  tail[5000] = '\0';
  const std::string huge = glycine_line + "\n" + tail;
  const status error = parse_error(huge);
  EXPECT_EQ(error.code(), errc::invalid_input);
  EXPECT_EQ(error.message(), "line 2: longer than 4096 bytes (limits.max_line_bytes)");
}

TEST(PqrReader, LongFieldsAreReadAndQuotedShortly) {
  mesh_limits limits;
  limits.max_line_bytes = 20'000'000;
  // A 10 MB line of fused fields and a 10 MB single field: read whole, and quoted in a bounded, escaped form.
  std::string fused = "ATOM";
  for (int i = 0; i < 1'000'000; ++i) fused += " 9-9-9";
  const status too_many = parse_error(fused + " 0.5 1.5", limits);
  EXPECT_TRUE(starts_with(too_many.message(), "line 1: ATOM record has 1000005 fields")) << too_many.message();
  const molecule mol = parse_ok("ATOM 1 N " + std::string(10'000'000, 'G') + " 1 9-9-9 0.5 1.5", limits);
  ASSERT_EQ(mol.atoms.size(), 1u);
  expect_atom(mol.atoms[0], 9, -9, -9, 0.5, 1.5);

  const std::string long_field = record("1", "2", "3", "0", std::string(10'000'000, '7') + "\xC3\xA9");
  const status error = parse_error(long_field, limits);
  EXPECT_EQ(error.code(), errc::invalid_input);
  EXPECT_EQ(error.message(), "line 1: radius '" + std::string(40, '7') +
                                 "...' is not a decimal number (records end with x y z charge radius)");

  const status escaped = parse_error(record("1", "2", "3", "0", "1\xC3\xA9\\"));
  EXPECT_EQ(escaped.message(),
            "line 1: radius '1\\xc3\\xa9\\x5c' is not a decimal number (records end with x y z charge radius)");
}

// ---- gzip ----------------------------------------------------------------------------------------------------

TEST(PqrReaderGzip, ReturnsPlainBytesUnchanged) {
  const std::string plain = glycine_line + "\n\x1f";
  const result<std::string> out = maybe_gunzip(plain, 10);  // max_bytes only bounds decompression
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(*out, plain);
  EXPECT_EQ(*maybe_gunzip("", 0), "");
}

TEST(PqrReaderGzip, DecompressesAMemberAndConcatenatedMembers) {
  const std::string compressed = read_bytes(test_data_path("pqr/glycine.pqr.gz"));
  const std::string expected = read_bytes(molecule_path("gly.pqr"));
  ASSERT_FALSE(expected.empty());
  const result<std::string> one = maybe_gunzip(compressed, expected.size());
  ASSERT_TRUE(one.ok()) << one.error().message();
  EXPECT_EQ(*one, expected);

  const result<std::string> three = maybe_gunzip(compressed + compressed + compressed, 3 * expected.size());
  ASSERT_TRUE(three.ok()) << three.error().message();
  EXPECT_EQ(*three, expected + expected + expected);
  EXPECT_EQ(parse_ok(*three).atoms.size(), 21u);
}

TEST(PqrReaderGzip, BoundsTheOutputSize) {
  const std::string compressed = read_bytes(test_data_path("pqr/glycine.pqr.gz"));
  const std::size_t size = read_bytes(molecule_path("gly.pqr")).size();
  const result<std::string> over = maybe_gunzip(compressed, size - 1);
  EXPECT_EQ(over.error().code(), errc::limit_exceeded);
  EXPECT_EQ(over.error().message(),
            "gzip: decompressed data is larger than " + std::to_string(size - 1) + " bytes");
  EXPECT_EQ(maybe_gunzip(compressed, 0).error().code(), errc::limit_exceeded);
  EXPECT_EQ(maybe_gunzip(compressed + compressed, 2 * size - 1).error().code(), errc::limit_exceeded);

  // 10 MB of zeros in 10 KB: stopped at the limit, without inflating the rest.
  const std::string bomb = read_bytes(test_data_path("pqr/ten_megabytes_of_zeros.gz"));
  EXPECT_EQ(maybe_gunzip(bomb, 1'000'000).error().code(), errc::limit_exceeded);
  const result<std::string> whole = maybe_gunzip(bomb, 10'000'000);
  ASSERT_TRUE(whole.ok()) << whole.error().message();
  EXPECT_EQ(whole->size(), 10'000'000u);
  EXPECT_EQ(whole->find_first_not_of('\0'), std::string::npos);
}

TEST(PqrReaderGzip, RejectsCorruptTruncatedOrTrailingData) {
  const std::string compressed = read_bytes(test_data_path("pqr/glycine.pqr.gz"));
  ASSERT_GT(compressed.size(), 40u);
  std::vector<std::string> broken;
  broken.push_back(compressed.substr(0, compressed.size() - 4));  // no ISIZE
  broken.push_back(compressed.substr(0, compressed.size() / 2));  // cut mid-stream
  broken.push_back(compressed.substr(0, 2));                      // magic only
  broken.push_back(compressed + "trailing garbage");
  broken.push_back(compressed + std::string(16, '\0'));
  std::string flipped_crc = compressed;
  flipped_crc[compressed.size() - 6] ^= 0x55;
  broken.push_back(flipped_crc);
  std::string forged_size = compressed;  // ISIZE claims ~4 GB: only a buffer-size hint, and then a length error
  forged_size.back() = '\xff';
  broken.push_back(forged_size);
  std::string bad_method = compressed;
  bad_method[2] = 7;  // compression method must be 8 (deflate)
  broken.push_back(bad_method);
  for (std::size_t i = 0; i < broken.size(); ++i) {
    const result<std::string> out = maybe_gunzip(broken[i], 1'000'000);
    EXPECT_EQ(out.error().code(), errc::invalid_input) << "case " << i;
    EXPECT_TRUE(starts_with(out.error().message(), "corrupt gzip stream: ")) << out.error().message();
  }
}

// ---- files and the real molecules -----------------------------------------------------------------------------

TEST(PqrReaderFile, ReportsUnreadableFilesWithTheirPath) {
  const std::filesystem::path missing = test_data_path("pqr/no_such_file.pqr");
  const result<molecule> absent = read_pqr_file(missing);
  EXPECT_EQ(absent.error().code(), errc::io_error);
  EXPECT_NE(absent.error().message().find(missing.string()), std::string::npos) << absent.error().message();

  const result<molecule> directory = read_pqr_file(test_data_path("pqr"));
  EXPECT_EQ(directory.error().code(), errc::io_error);
  EXPECT_NE(directory.error().message().find("pqr"), std::string::npos) << directory.error().message();
}

TEST(PqrReaderFile, BoundsTheFileSizeByMaxAtoms) {
  mesh_limits limits;
  limits.max_atoms = 100;  // 20,000 bytes: fas2.pqr (61,608 bytes, 906 atoms) is larger
  const result<molecule> plain = read_pqr_file(molecule_path("fas2.pqr"), limits);
  EXPECT_EQ(plain.error().code(), errc::limit_exceeded);
  EXPECT_NE(plain.error().message().find("is larger than 20000 bytes"), std::string::npos) << plain.error().message();

  limits.max_atoms = 20'000;  // 4 MB: the 1.6 MB file passes, its 7 MB of text does not
  const result<molecule> compressed = read_pqr_file(molecule_path("1k4r_5asu.pqr.gz"), limits);
  EXPECT_EQ(compressed.error().code(), errc::limit_exceeded);
  EXPECT_TRUE(starts_with(compressed.error().message(), "gzip: decompressed data is larger than 4000000 bytes"))
      << compressed.error().message();

  EXPECT_EQ(max_pqr_text_bytes(limits), 4'000'000u);
  limits.max_atoms = std::numeric_limits<std::size_t>::max() / 2;
  EXPECT_EQ(max_pqr_text_bytes(limits), std::numeric_limits<std::size_t>::max());
}

TEST(PqrReaderFile, ReadsExactValuesOfFas2) {
  const result<molecule> fas2 = read_pqr_file(molecule_path("fas2.pqr"));
  ASSERT_TRUE(fas2.ok()) << fas2.error().message();
  ASSERT_EQ(fas2->atoms.size(), 906u);
  // ATOM   8280  N   NTE   544     -13.336   3.045  35.885  0.185 1.824
  expect_atom(fas2->atoms.front(), -13.336, 3.045, 35.885, 0.185, 1.824);
  // ATOM   9185  OT2 CTE   604      -2.616   6.176  22.613 -0.817 1.661
  expect_atom(fas2->atoms.back(), -2.616, 6.176, 22.613, -0.817, 1.661);
}

TEST(PqrReaderFile, ReadsAdpHetatmRecords) {
  const result<molecule> adp = read_pqr_file(molecule_path("adp.pqr"));
  ASSERT_TRUE(adp.ok()) << adp.error().message();
  ASSERT_EQ(adp->atoms.size(), 39u);
  // HETATM    1  PB  ADP     1      44.669   2.928  38.556  -0.0068  1.800
  expect_atom(adp->atoms.front(), 44.669, 2.928, 38.556, -0.0068, 1.8);
}

TEST(PqrReaderFile, GzipAndPlainFilesReadTheSame) {
  const std::filesystem::path compressed = test_data_path("pqr/glycine.pqr.gz");
  const result<molecule> from_gzip = read_pqr_file(compressed);
  const result<molecule> from_text = read_pqr_file(molecule_path("gly.pqr"));
  ASSERT_TRUE(from_gzip.ok()) << from_gzip.error().message();
  ASSERT_TRUE(from_text.ok()) << from_text.error().message();
  ASSERT_EQ(from_gzip->atoms.size(), 7u);
  ASSERT_EQ(from_text->atoms.size(), 7u);
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_EQ(from_gzip->atoms[i].center, from_text->atoms[i].center);
    EXPECT_EQ(from_gzip->atoms[i].radius, from_text->atoms[i].radius);
    EXPECT_EQ(from_gzip->atoms[i].charge, from_text->atoms[i].charge);
  }
  expect_atom(from_text->atoms[6], -11.157, -0.775, 37.657, -0.568, 1.661);
}

struct ladder_molecule {
  std::string file;
  std::size_t atoms;
  std::size_t zero_radii;
};

class PqrReaderLadder : public ::testing::TestWithParam<ladder_molecule> {};

TEST_P(PqrReaderLadder, ReadsEveryAtom) {
  const ladder_molecule& expected = GetParam();
  const result<molecule> mol = read_pqr_file(molecule_path(expected.file));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  EXPECT_EQ(mol->atoms.size(), expected.atoms);
  EXPECT_EQ(mol->zero_radius_atoms, expected.zero_radii);
  for (const atom& a : mol->atoms) {
    ASSERT_TRUE(std::isfinite(a.center.x) && std::isfinite(a.center.y) && std::isfinite(a.center.z));
    ASSERT_LE(std::fabs(a.center.x), 1000.0);  // the README's bounding boxes stay under 510 Å
    ASSERT_TRUE(a.radius == 0 || (a.radius >= 0.6 && a.radius <= 2.1)) << a.radius;
  }
}

INSTANTIATE_TEST_SUITE_P(
    SharedMolecules, PqrReaderLadder,
    ::testing::Values(ladder_molecule{"gly.pqr", 7, 0}, ladder_molecule{"adp.pqr", 39, 0},
                      ladder_molecule{"villin_1vii.pqr", 596, 3}, ladder_molecule{"fas2.pqr", 906, 0},
                      ladder_molecule{"mache.pqr", 8279, 0}, ladder_molecule{"achbp.pqr", 16090, 0},
                      ladder_molecule{"3j6r_asu.pqr", 17214, 0}, ladder_molecule{"1ihm_asu.pqr", 22281, 259},
                      ladder_molecule{"2buk_12asu.pqr", 34284, 408},
                      ladder_molecule{"1k4r_5asu.pqr.gz", 90180, 945}),
    [](const ::testing::TestParamInfo<ladder_molecule>& info) {
      std::string name = info.param.file;
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

}  // namespace
}  // namespace tracemesh
