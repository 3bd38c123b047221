// The command's input format: a file's extension declares it (.pqr, .pdb, .cif, .xyzr, each also .gz), a
// contradicted extension and a damaged PQR file fail with one line, and the report says what was read.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/structure_writers.hpp"
#include "support/test_paths.hpp"
#include "support/text_files.hpp"

namespace tracemesh::cli_input_format_test {

namespace fs = std::filesystem;

struct run_result {
  int exit_code = -1;
  std::string err;
};

using tracemesh::testing::gzip;
using tracemesh::testing::read_file;
using tracemesh::testing::shell_quote;

/// A PDB record without element symbols: it ends with occupancy and B-factor, five numbers, like a PQR record.
const char* const pdb_record_without_element = "ATOM      1  CA  GLY A   1      -8.901   4.127  -0.555  1.00  7.73\n";

class CliInputFormat : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("tracemesh_cli_input_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& content) const {
    std::ofstream(dir_ / name, std::ios::binary) << content;
    return dir_ / name;
  }

  /// Runs tracemesh on `input` with a report (and `extra` arguments), stdout discarded and stderr captured.
  run_result run(const fs::path& input, const std::vector<std::string>& extra = {}) const {
    std::string command = shell_quote(tracemesh::testing::binary_path("tracemesh").string());
    std::vector<std::string> args{input.string(), "-o", (dir_ / "out.off").string(), "--report",
                                  (dir_ / "report.json").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    for (const std::string& arg : args) {
      command += ' ';
      command += shell_quote(arg);
    }
    command += " < /dev/null > /dev/null 2> ";
    command += shell_quote((dir_ / "stderr").string());
    const int raw = std::system(command.c_str());
    run_result result;
    result.exit_code = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    result.err = read_file(dir_ / "stderr");
    return result;
  }

  /// The report's "input" section after a successful run.
  nlohmann::json input_read(const fs::path& input, const std::vector<std::string>& extra = {}) const {
    const run_result result = run(input, extra);
    EXPECT_EQ(result.exit_code, 0) << input << ": " << result.err;
    const nlohmann::json report = nlohmann::json::parse(read_file(dir_ / "report.json"), nullptr, false);
    if (report.is_discarded() || !report.contains("input")) return nullptr;
    return report.at("input");
  }

  static void expect_one_line_failure(const run_result& result, const std::string& mentions) {
    EXPECT_EQ(result.exit_code, 1) << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_TRUE(result.err.starts_with("tracemesh: ")) << result.err;
    EXPECT_NE(result.err.find(mentions), std::string::npos) << result.err;
  }

  fs::path dir_;
};

TEST_F(CliInputFormat, APqrWithAnUnreadableFirstRadiusFailsNamingTheLine) {
  const std::string gly = read_file(tracemesh::testing::molecule_path("gly.pqr"));
  const std::size_t end = gly.find('\n');
  const std::string damaged = gly.substr(0, gly.rfind(' ', end) + 1) + "*****" + gly.substr(end);
  expect_one_line_failure(run(write("gly.pqr", damaged)), "line 1: radius '*****'");
  expect_one_line_failure(run(write("gly.txt", damaged)), "line 1: radius '*****'");  // detected: PQR all the same
}

TEST_F(CliInputFormat, TheExtensionDeclaresTheFormat) {
  EXPECT_EQ(input_read(write("a.txt", pdb_record_without_element)),
            nlohmann::json({{"format", "pqr"}, {"radii", "file"}}))
      << "detected: the ambiguous record reads as PQR";
  EXPECT_EQ(input_read(write("a.pdb", pdb_record_without_element)),
            nlohmann::json({{"format", "pdb"}, {"radii", "bondi"}}));
  EXPECT_EQ(input_read(write("a.PDB.gz", gzip(pdb_record_without_element))),
            nlohmann::json({{"format", "pdb"}, {"radii", "bondi"}}));
  const auto atoms = tracemesh::testing::atoms_of_pqr(read_file(tracemesh::testing::molecule_path("gly.pqr")));
  EXPECT_EQ(input_read(write("gly.cif.gz", gzip(tracemesh::testing::to_mmcif(atoms)))),
            nlohmann::json({{"format", "mmcif"}, {"radii", "bondi"}}));
  EXPECT_EQ(input_read(write("gly.xyzr", tracemesh::testing::to_xyzr(atoms, tracemesh::radii_set::bondi))),
            nlohmann::json({{"format", "xyzr"}, {"radii", "file"}}));
}

TEST_F(CliInputFormat, AnExtensionTheContentContradictsFailsWithOneLine) {
  const std::string gly = read_file(tracemesh::testing::molecule_path("gly.pqr"));
  expect_one_line_failure(run(write("gly.cif", gly)),
                          "the file name 'gly.cif' declares mmcif, but the text is not mmCIF");
  expect_one_line_failure(run(write("gly.xyzr.gz", gzip(gly))), "declares xyzr, but the text has ATOM/HETATM records");
  const auto atoms = tracemesh::testing::atoms_of_pqr(gly);
  expect_one_line_failure(run(write("gly.pqr", tracemesh::testing::to_mmcif(atoms))),
                          "the file name 'gly.pqr' declares pqr, but the text is mmCIF");
}

TEST_F(CliInputFormat, FormatInDeclaresTheFormatOverTheExtension) {
  EXPECT_EQ(input_read(write("a.pqr.txt", pdb_record_without_element), {"--format-in", "pdb"}),
            nlohmann::json({{"format", "pdb"}, {"radii", "bondi"}}));
  const std::string gly = read_file(tracemesh::testing::molecule_path("gly.pqr"));
  expect_one_line_failure(run(write("gly.pqr", gly), {"--format-in", "xyzr"}),
                          "declares xyzr, but the text has ATOM/HETATM records");
  const run_result unknown = run(write("gly.pqr", gly), {"--format-in", "gro"});
  EXPECT_EQ(unknown.exit_code, 2) << "a usage error";
  EXPECT_EQ(unknown.err, "tracemesh: --format-in must be pqr, pdb, mmcif or xyzr, not 'gro' (see tracemesh --help)\n");
}

}  // namespace tracemesh::cli_input_format_test
