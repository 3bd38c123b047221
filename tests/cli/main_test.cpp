// Black-box tests of the `tracemesh` executable: exit codes, the one-line error contract, outputs and atomicity.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/mesher.hpp"
#include "support/held_jobs.hpp"
#include "support/pqr_edits.hpp"
#include "support/sanitized_build.hpp"
#include "support/structure_writers.hpp"
#include "support/shell_xyzr.hpp"
#include "support/terminal_child.hpp"
#include "support/test_paths.hpp"
#include "support/text_files.hpp"

namespace {

namespace fs = std::filesystem;

struct run_result {
  int exit_code = -1;
  std::string out;
  std::string err;
};

using tracemesh::testing::read_file;
using tracemesh::testing::shell_quote;

std::size_t line_count(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

/// A scratch directory per test, removed afterwards.
class TracemeshCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("tracemesh_cli_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path path(const std::string& name) const { return dir_ / name; }

  fs::path write(const std::string& name, const std::string& content) const {
    std::ofstream(path(name), std::ios::binary) << content;
    return path(name);
  }

  /// Runs tracemesh with `args` (each shell-quoted), stdout and stderr captured, stdin from /dev/null.
  run_result run(const std::vector<std::string>& args) const {
    std::string command = shell_quote(tracemesh::testing::binary_path("tracemesh").string());
    // Appended piece by piece: g++ 12 raises a false -Wrestrict on `" " + std::string`.
    for (const std::string& arg : args) {
      command += ' ';
      command += shell_quote(arg);
    }
    command += " < /dev/null > ";
    command += shell_quote(path("stdout").string());
    command += " 2> ";
    command += shell_quote(path("stderr").string());
    const int raw = std::system(command.c_str());
    run_result result;
    result.exit_code = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    result.out = read_file(path("stdout"));
    result.err = read_file(path("stderr"));
    fs::remove(path("stdout"));
    fs::remove(path("stderr"));
    return result;
  }

  /// The files the test directory holds (names only).
  std::vector<std::string> files() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  /// The failure contract: the expected exit code, exactly one stderr line "tracemesh: ...", nothing on stdout.
  static void expect_one_line_failure(const run_result& result, int exit_code, const std::string& mentions = "") {
    EXPECT_EQ(result.exit_code, exit_code) << result.err;
    EXPECT_EQ(line_count(result.err), 1U) << result.err;
    EXPECT_EQ(result.err.rfind("tracemesh: ", 0), 0U) << result.err;
    EXPECT_NE(result.err.find(mentions), std::string::npos) << result.err;
    EXPECT_TRUE(result.out.empty()) << result.out;
  }

  fs::path dir_;
};

const char* const garbage_pqr = "ATOM      1  N   GLY     1      -1.0   abc   0.5 -0.3 1.5\n";
const char* const one_atom_pqr = "ATOM      1  C   GLY     1       1.0   2.0   3.0  0.0 1.7\n";

struct parsed_off {
  std::size_t vertices = 0, triangles = 0;
  bool ok = false;
};

/// Checks the OFF structure fully: header, counts, every vertex and triangle line, indices in range.
parsed_off parse_off(const std::string& text) {
  parsed_off off;
  std::istringstream in(text);
  std::string magic;
  std::size_t edges = 1;
  if (!(in >> magic >> off.vertices >> off.triangles >> edges) || magic != "OFF" || edges != 0) return off;
  for (std::size_t i = 0; i < off.vertices; ++i) {
    double x, y, z;
    if (!(in >> x >> y >> z)) return off;
  }
  for (std::size_t f = 0; f < off.triangles; ++f) {
    std::size_t corners, a, b, c;
    if (!(in >> corners >> a >> b >> c) || corners != 3 || a >= off.vertices || b >= off.vertices ||
        c >= off.vertices) {
      return off;
    }
  }
  std::string rest;
  off.ok = !(in >> rest);
  return off;
}

// ---------------------------------------------------------------------------------------------------------------
// Misuse: exit code 2

TEST_F(TracemeshCli, NoArgumentsIsUsage) { expect_one_line_failure(run({}), 2); }

TEST_F(TracemeshCli, MissingOutputIsUsage) {
  expect_one_line_failure(run({write("a.pqr", one_atom_pqr).string()}), 2, "output");
}

TEST_F(TracemeshCli, UnknownOptionIsUsage) {
  expect_one_line_failure(run({write("a.pqr", one_atom_pqr).string(), "-o", path("a.off").string(), "--bogus"}),
                          2, "--bogus");
}

TEST_F(TracemeshCli, BadParametersAreUsageAndNameTheParameter) {
  const std::string input = write("a.pqr", one_atom_pqr).string();
  const std::string output = path("a.off").string();
  expect_one_line_failure(run({input, "-o", output, "--density", "abc"}), 2, "density");
  expect_one_line_failure(run({input, "-o", output, "--density", "nan"}), 2, "density");
  expect_one_line_failure(run({input, "-o", output, "--density", "0"}), 2, "density");
  expect_one_line_failure(run({input, "-o", output, "--d", "1"}), 2, "tracemesh: d");
  expect_one_line_failure(run({input, "-o", output, "--t0", "-1"}), 2, "t0");
  expect_one_line_failure(run({input, "-o", output, "--t0", "1\nsecond line"}), 2, "t0");
  expect_one_line_failure(run({input, "-o", output, "--threads", "many"}), 2, "threads");
  expect_one_line_failure(run({input, "-o", output, "--format", "obj"}), 2, "format");
  expect_one_line_failure(run({input, "-o", path("a.xyz").string()}), 2, "format");
  EXPECT_EQ(files(), std::vector<std::string>{"a.pqr"}) << "nothing written on misuse";
}

TEST_F(TracemeshCli, BadMethodRefineAndTraceOptionsAreUsageAndNameTheOption) {
  const std::string input = write("a.pqr", one_atom_pqr).string();
  const std::string output = path("a.off").string();
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--method", "Trace"},          {"--method", "marching"},          {"--method", ""},
      {"--refine", "partial"},        {"--refine", "FULL"},              {"--trace-degree", "2.5"},
      {"--trace-degree", "1"},        {"--trace-degree", "31"},          {"--trace-degree", "1e300"},
      {"--trace-degree", "ten"},      {"--trace-step", "0"},             {"--trace-step", "2.5"},
      {"--trace-step", "nan"},        {"--trace-cos-bound", "1"},        {"--trace-cos-bound", "0.4"},
      {"--trace-extreme-tolerance", "0"}, {"--trace-extreme-tolerance", "0.3"},
      {"--trace-extreme-tolerance", "1e-2\nsecond line"}};
  for (const auto& [option, value] : bad) {
    SCOPED_TRACE(option + " " + value);
    // The message names the option as it is spelled here, without its dashes ("trace-degree must be ...").
    expect_one_line_failure(run({input, "-o", output, option, value}), 2, "tracemesh: " + option.substr(2));
    // The trace options are checked whatever the method.
    expect_one_line_failure(run({input, "-o", output, "--method", "lattice", option + "=" + value}), 2,
                            option.substr(2));
  }
  expect_one_line_failure(run({input, "-o", output, "--trace_degree", "12"}), 2, "--trace_degree");
  expect_one_line_failure(run({input, "-o", output, "--method"}), 2, "--method");
  EXPECT_EQ(files(), std::vector<std::string>{"a.pqr"}) << "nothing written on misuse";
}

TEST_F(TracemeshCli, HelpDocumentsMethodRefineAndTraceOptions) {
  const run_result help = run({"--help"});
  ASSERT_EQ(help.exit_code, 0);
  const tracemesh::mesh_params defaults;
  const std::vector<std::string> expected = {
      "--method", "--refine", "--trace-degree", "--trace-step", "--trace-cos-bound", "--trace-extreme-tolerance",
      "trace|lattice", "none|full", std::string("default ") + tracemesh::method_name(defaults.method),
      std::string("default ") + tracemesh::refine_name(defaults.refine),
      "default " + std::to_string(defaults.trace.legendre_degree)};
  for (const std::string& text : expected) {
    EXPECT_NE(help.out.find(text), std::string::npos) << text << " in\n" << help.out;
  }
}

TEST_F(TracemeshCli, HelpAndVersionSucceed) {
  const run_result help = run({"--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--density"), std::string::npos);
  EXPECT_TRUE(help.err.empty());
  const run_result version = run({"--version"});
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_NE(version.out.find("tracemesh"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------------------------
// Bad input: exit code 1

TEST_F(TracemeshCli, MissingInputFile) {
  expect_one_line_failure(run({path("absent.pqr").string(), "-o", path("a.off").string()}), 1, "absent.pqr");
}

TEST_F(TracemeshCli, GarbagePqr) {
  expect_one_line_failure(run({write("bad.pqr", garbage_pqr).string(), "-o", path("bad.off").string()}), 1,
                          "line 1");
  EXPECT_FALSE(fs::exists(path("bad.off")));
}

// Issue 12, finding 8: a PQR line with a missing column was read with its columns shifted (a wrong mesh).
TEST_F(TracemeshCli, APqrLineWithAMissingColumnIsRejectedNamingTheLine) {
  const std::string fas2 = read_file(tracemesh::testing::molecule_path("fas2.pqr"));
  const std::string damaged = tracemesh::testing::without_field(tracemesh::testing::with_chain_id(fas2, "A"), 100, 8);
  expect_one_line_failure(run({write("damaged.pqr", damaged).string(), "-o", path("damaged.off").string()}), 1,
                          "line 100: residue number 'A' is not an integer");
  EXPECT_FALSE(fs::exists(path("damaged.off")));
}

// Issue 11, item 5: the command reads PDB, mmCIF and xyzr (told from the content) with the service's options.
TEST_F(TracemeshCli, ReadsPdbWithTheInputOptions) {
  const auto atoms = tracemesh::testing::atoms_of_pqr(read_file(tracemesh::testing::molecule_path("gly.pqr")));
  const fs::path pdb = write("gly.txt", tracemesh::testing::to_pdb(atoms));  // the name says nothing
  const run_result meshed = run({pdb.string(), "-o", path("gly.off").string(), "--radii", "mantina",
                                 "--hydrogens", "drop", "--report", "-"});
  ASSERT_EQ(meshed.exit_code, 0) << meshed.err;
  const std::size_t key = meshed.out.find("\"atoms_meshed\"");
  ASSERT_NE(key, std::string::npos) << meshed.out.substr(0, 300);
  const std::size_t value = meshed.out.find_first_of("0123456789", key);
  EXPECT_EQ(std::stoul(meshed.out.substr(value)), 4U) << "N, CA, C and O: the three hydrogens dropped";
  expect_one_line_failure(run({pdb.string(), "-o", path("x.off").string(), "--radii", "vdw"}), 2,
                          "--radii must be bondi or mantina");
  expect_one_line_failure(run({pdb.string(), "-o", path("x.off").string(), "--waters", "yes"}), 2,
                          "--waters must be keep or drop");
}

// The deposited 2BUK entry (one coat protein, three calcium ions) meshed as its 60-copy capsid (issue 35): the report
// names the assembly, and the mesh is certified. Mantina's radii: the Bondi set has none for calcium. The lattice
// path at 0.3 v/Å² keeps the run short (85,712 atoms).
TEST_F(TracemeshCli, MeshesTheBiologicalAssemblyOfADepositedEntry) {
  const std::string entry = tracemesh::testing::test_data_path("molecules/2buk.pdb.gz").string();
  const fs::path glb = path("capsid.glb");
  const run_result meshed = run({entry, "--assembly", "1", "--radii", "mantina", "-o", glb.string(), "--method",
                                 "lattice", "--density", "0.3", "--report", "-"});
  ASSERT_EQ(meshed.exit_code, 0) << meshed.err;
  const nlohmann::json report = nlohmann::json::parse(meshed.out);
  EXPECT_EQ(report.at("input").at("assembly"),
            nlohmann::json({{"id", "1"}, {"operators", 60}, {"atoms", 85712}, {"merged_atoms", 88}}));
  EXPECT_EQ(report.at("atoms_meshed"), 85712) << "60 × 1,430 atoms, the 88 copies of ions on symmetry axes merged";
  EXPECT_EQ(report.at("certificate").at("certified"), true) << report.at("certificate");
  EXPECT_GT(fs::file_size(glb), 0U);

  expect_one_line_failure(run({entry, "--assembly", "9", "-o", path("x.glb").string()}), 1,
                          "assembly '9' is not in the file: its assemblies are 1, or asu");
  expect_one_line_failure(run({entry, "--assembly", "1 2", "-o", path("x.glb").string()}), 2,
                          "--assembly must be asu or an assembly id");
  expect_one_line_failure(run({tracemesh::testing::molecule_path("gly.pqr").string(), "--assembly", "1", "-o",
                               path("x.off").string()}),
                          1, "assembly '1': a PQR file has no symmetry operators");
  EXPECT_FALSE(fs::exists(path("x.glb")));
  EXPECT_FALSE(fs::exists(path("x.off")));
}

TEST_F(TracemeshCli, BinaryInput) {
  std::string bytes(4096, '\0');
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 7919 % 256);
  expect_one_line_failure(run({write("noise.pqr", bytes).string(), "-o", path("noise.off").string()}), 1);
}

TEST_F(TracemeshCli, NothingToMesh) {
  expect_one_line_failure(run({write("empty.pqr", "REMARK nothing here\nEND\n").string(), "-o",
                               path("empty.off").string()}),
                          1);
}

TEST_F(TracemeshCli, UnwritableOutput) {
  expect_one_line_failure(run({write("a.pqr", one_atom_pqr).string(), "-o", path("no/such/dir/a.off").string()}),
                          1, "a.off");
}

TEST_F(TracemeshCli, FailedRunLeavesAnExistingOutputUntouched) {
  write("keep.off", "previous content");
  expect_one_line_failure(run({write("bad.pqr", garbage_pqr).string(), "-o", path("keep.off").string()}), 1);
  EXPECT_EQ(read_file(path("keep.off")), "previous content");
  EXPECT_EQ(files(), (std::vector<std::string>{"bad.pqr", "keep.off"})) << "no temporary file left behind";
}

// ---------------------------------------------------------------------------------------------------------------
// Success on real molecules (needs the mesher)

TEST_F(TracemeshCli, CavitiesDropRemovesTheEnclosedComponentsAndKeepFlagsThem) {
  const fs::path shell = write("shell.xyzr", tracemesh::testing::shell_with_island_xyzr());
  for (const std::string mode : {"keep", "drop"}) {
    const run_result result = run({shell.string(), "-o", path(mode + ".ply").string(), "--cavities", mode,
                                   "--report", path(mode + ".json").string()});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    const nlohmann::json report = nlohmann::json::parse(read_file(path(mode + ".json")));
    EXPECT_EQ(report.at("certificate").at("certified"), true);
    EXPECT_EQ(report.at("cavity_mode"), mode);
    std::size_t enclosed = 0;
    for (const auto& component : report.at("components")) enclosed += component.at("enclosed").get<bool>() ? 1 : 0;
    EXPECT_EQ(report.at("components").size(), mode == "keep" ? 3U : 1U);
    EXPECT_EQ(enclosed, mode == "keep" ? 2U : 0U);
    EXPECT_EQ(report.at("dropped_components"), mode == "keep" ? 0 : 2);
  }
  expect_one_line_failure(run({shell.string(), "-o", path("x.off").string(), "--cavities", "remove"}), 2,
                          "cavities");
}

TEST_F(TracemeshCli, MeshesGlycineToOffWithACertifiedReport) {
  const run_result result = run({tracemesh::testing::molecule_path("gly.pqr").string(), "-o",
                                 path("gly.off").string(), "--report", path("gly.json").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_TRUE(result.err.empty()) << "quiet by default, no progress bar off a TTY: " << result.err;
  EXPECT_TRUE(result.out.empty());
  const parsed_off off = parse_off(read_file(path("gly.off")));
  ASSERT_TRUE(off.ok);
  EXPECT_GT(off.vertices, 100U);
  const nlohmann::json report = nlohmann::json::parse(read_file(path("gly.json")));
  EXPECT_EQ(report.at("certificate").at("certified"), true);
  EXPECT_EQ(report.at("vertices"), off.vertices);
  EXPECT_EQ(report.at("triangles"), off.triangles);
  EXPECT_EQ(report.at("atoms_meshed"), 7);
  EXPECT_EQ(report.at("components").size(), 1U);
  EXPECT_EQ(report.at("genus"), 0);
  EXPECT_TRUE(report.at("timings").contains("encoding"));
  EXPECT_EQ(files(), (std::vector<std::string>{"gly.json", "gly.off"}));
}

TEST_F(TracemeshCli, MeshesFasciculinWithTheReportOnStdout) {
  const run_result result = run({tracemesh::testing::molecule_path("fas2.pqr").string(), "-o",
                                 path("fas2.off").string(), "--report", "-", "--density", "1.0", "--d=-1",
                                 "--t0", "1"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const nlohmann::json report = nlohmann::json::parse(result.out);
  EXPECT_EQ(report.at("certificate").at("certified"), true);
  EXPECT_EQ(report.at("atoms_meshed"), 906);
  EXPECT_EQ(report.at("parameters"), (nlohmann::json{{"density", 1.0}, {"d", -1.0}, {"t0", 1.0}}));
  const parsed_off off = parse_off(read_file(path("fas2.off")));
  ASSERT_TRUE(off.ok);
  EXPECT_EQ(report.at("vertices"), off.vertices);
  EXPECT_EQ(report.at("triangles"), off.triangles);
}

TEST_F(TracemeshCli, DefaultMethodAndRefineAreTheEnginesAndAreReported) {
  const run_result result = run({tracemesh::testing::molecule_path("gly.pqr").string(), "-o",
                                 path("gly.off").string(), "--report", "-"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const nlohmann::json report = nlohmann::json::parse(result.out);
  const tracemesh::mesh_params defaults;
  EXPECT_EQ(report.at("method"), tracemesh::method_name(defaults.method));
  EXPECT_EQ(report.at("refine"), tracemesh::refine_name(defaults.refine));
  EXPECT_EQ(report.at("trace").is_null(), defaults.method == tracemesh::mesh_method::lattice);
  // The defaults spelled out give the very same mesh.
  const run_result spelled = run({tracemesh::testing::molecule_path("gly.pqr").string(), "-o",
                                  path("spelled.off").string(), "--method", tracemesh::method_name(defaults.method),
                                  "--refine", tracemesh::refine_name(defaults.refine), "--trace-degree",
                                  std::to_string(defaults.trace.legendre_degree), "--trace-step=0.5"});
  ASSERT_EQ(spelled.exit_code, 0) << spelled.err;
  EXPECT_EQ(read_file(path("spelled.off")), read_file(path("gly.off")));
}

/// The report of a certified run of `molecule` with `args`, checked against the OFF it wrote.
nlohmann::json certified_report(const run_result& result, const std::string& off_text) {
  EXPECT_EQ(result.exit_code, 0) << result.err;
  if (result.exit_code != 0) return nlohmann::json::object();
  const nlohmann::json report = nlohmann::json::parse(result.out);
  EXPECT_EQ(report.at("certificate").at("certified"), true) << report.at("certificate");
  const parsed_off off = parse_off(off_text);
  EXPECT_TRUE(off.ok);
  EXPECT_EQ(report.at("vertices"), off.vertices);
  EXPECT_EQ(report.at("triangles"), off.triangles);
  return report;
}

TEST_F(TracemeshCli, LatticeMethodWithAndWithoutRefinementGivesCertifiedMeshes) {
  for (const char* molecule : {"gly.pqr", "fas2.pqr"}) {
    std::size_t vertices[2] = {0, 0};
    for (const char* refine : {"none", "full"}) {
      SCOPED_TRACE(std::string(molecule) + " refine " + refine);
      const fs::path off = path(std::string(molecule) + "." + refine + ".off");
      const run_result result = run({tracemesh::testing::molecule_path(molecule).string(), "-o", off.string(),
                                     "--method", "lattice", "--refine", refine, "--report", "-"});
      const nlohmann::json report = certified_report(result, read_file(off));
      if (report.empty()) continue;
      EXPECT_EQ(report.at("method"), "lattice");
      EXPECT_EQ(report.at("refine"), refine);
      EXPECT_TRUE(report.at("trace").is_null());
      EXPECT_EQ(report.at("timings").contains("refining"), std::string(refine) == "full") << report.at("timings");
      EXPECT_TRUE(report.at("timings").contains("sampling"));
      EXPECT_FALSE(report.at("timings").contains("tracing"));
      vertices[std::string(refine) == "full"] = report.at("vertices").get<std::size_t>();
    }
    EXPECT_GT(vertices[0], vertices[1]) << molecule << ": the quality pass coarsens marching tetrahedra's mesh";
  }
}

// The trace method end to end on real molecules: certified meshes and the trace section of the report.
TEST_F(TracemeshCli, TraceMethodGivesCertifiedMeshesWithTraceReports) {
  for (const char* molecule : {"gly.pqr", "fas2.pqr"}) {
    for (const char* refine : {"none", "full"}) {
      SCOPED_TRACE(std::string(molecule) + " refine " + refine);
      const fs::path off = path(std::string(molecule) + "." + refine + ".off");
      const run_result result = run({tracemesh::testing::molecule_path(molecule).string(), "-o", off.string(),
                                     "--method", "trace", "--refine", refine, "--report", "-"});
      const nlohmann::json report = certified_report(result, read_file(off));
      if (report.empty()) continue;
      EXPECT_EQ(report.at("method"), "trace");
      EXPECT_EQ(report.at("refine"), refine);
      const nlohmann::json& trace = report.at("trace");
      ASSERT_TRUE(trace.is_object()) << report;
      EXPECT_GT(trace.at("lines").get<double>(), 0);
      EXPECT_GT(trace.at("polygons").get<double>(), 0);
      EXPECT_GT(trace.at("raw_vertices").get<double>(), 0);
      EXPECT_GT(trace.at("field_evaluations_per_vertex").get<double>(), 0);
      EXPECT_TRUE(trace.contains("fallback_loops"));
      EXPECT_TRUE(trace.at("fallback_loops").is_number_unsigned());
      const tracemesh::trace_parameters defaults;
      EXPECT_EQ(trace.at("parameters").at("legendre_degree"), defaults.legendre_degree);
      EXPECT_EQ(trace.at("parameters").at("step_fraction"), defaults.step_fraction);
      EXPECT_GT(trace.at("parameters").at("line_spacing").get<double>(), 0);
      EXPECT_DOUBLE_EQ(trace.at("parameters").at("step").get<double>(),
                       defaults.step_fraction * trace.at("parameters").at("line_spacing").get<double>());
      EXPECT_TRUE(report.at("timings").contains("tracing")) << report.at("timings");
      EXPECT_FALSE(report.at("timings").contains("sampling")) << report.at("timings");
      EXPECT_EQ(report.at("timings").contains("refining"), std::string(refine) == "full");
      if (std::string(refine) == "none") {
        // No quality pass: the polygons' vertices, less one per short edge collapsed for delivery.
        const auto collapsed = trace.at("collapsed_raw_edges").get<std::size_t>();
        EXPECT_GT(collapsed, 0u);
        EXPECT_EQ(report.at("vertices").get<std::size_t>() + collapsed, trace.at("raw_vertices").get<std::size_t>());
        EXPECT_EQ(report.at("triangles").get<std::size_t>() + 2 * collapsed,
                  trace.at("raw_triangles").get<std::size_t>());
      }
    }
  }
}

// mache with a sharp kernel leaves cells the trace path cannot close on any line grid (tests/core/mesher_test.cpp):
// the CLI still writes a certified mesh, made by the lattice path, warns in one line and says so in the report.
TEST_F(TracemeshCli, ATraceJobThatFallsBackToTheLatticePathWarnsAndSaysSoInTheReport) {
  // Release suite only: the job (three line grids, then the lattice path) takes minutes under a sanitizer, and
  // mesher_fallback in tests/core/mesher_test.cpp runs it there. What this test adds is bookkeeping:
  // the warning line and the report's fields.
  if (tracemesh::testing::sanitized_build()) {
    GTEST_SKIP() << "Release suite only: core mesher_fallback runs this job under the sanitizers";
  }
  const fs::path off = path("mache.off");
  const run_result result =
      run({tracemesh::testing::molecule_path("mache.pqr").string(), "-o", off.string(), "--d=-20", "--t0", "3",
           "--density", "0.1", "--method", "trace", "--report", "-"});
  const nlohmann::json report = certified_report(result, read_file(off));
  ASSERT_FALSE(report.empty());
  EXPECT_EQ(report.at("method"), "trace");
  EXPECT_EQ(report.at("method_used"), "lattice");
  EXPECT_NE(report.at("fallback").get<std::string>().find("could not be closed"), std::string::npos);
  EXPECT_TRUE(report.at("trace").is_null());
  EXPECT_GT(report.at("timings").at("failed_attempts").get<double>(), 0.0);
  EXPECT_EQ(line_count(result.err), 1u) << result.err;
  EXPECT_EQ(result.err.rfind("tracemesh: warning: the trace path failed (", 0), 0u) << result.err;
}

// A job whose first line grid leaves a cell open and whose second closes it: no warning (the mesh is the trace
// path's), and the report says where the lines were and how long the failed attempt took.
TEST_F(TracemeshCli, ATraceRetriedOnAnotherLineGridSaysSoInTheReport) {
  // The input of tests/core/mesher_test.cpp's retry test: its first line grid leaves a cell open, the second closes it.
  const fs::path off = path("mache.off");
  const run_result result =
      run({tracemesh::testing::molecule_path("mache.pqr").string(), "-o", off.string(), "--d=-12", "--t0", "1",
           "--density", "0.5", "--method", "trace", "--refine", "none", "--report", "-"});
  const nlohmann::json report = certified_report(result, read_file(off));
  ASSERT_FALSE(report.empty());
  EXPECT_EQ(report.at("method_used"), "trace");
  EXPECT_TRUE(report.at("fallback").is_null());
  EXPECT_EQ(report.at("trace").at("grid_retries"), 1);
  EXPECT_EQ(report.at("trace").at("line_offset"), nlohmann::json::parse("[0.5, 0.5]"));
  const nlohmann::json& timings = report.at("timings");
  const double failed = timings.at("failed_attempts").get<double>();
  EXPECT_GT(failed, 0.0);
  double sum = 0;
  for (const auto& [stage, seconds] : timings.items()) {
    if (stage != "total") sum += seconds.get<double>();
  }
  EXPECT_NEAR(timings.at("total").get<double>(), sum, 1e-9) << "the failed attempt is part of the total";
  EXPECT_TRUE(result.err.empty()) << result.err;
}

TEST_F(TracemeshCli, TraceMethodTakesItsParametersAndPrintsTheTracingStage) {
  const fs::path off = path("gly.off");
  const run_result result =
      run({tracemesh::testing::molecule_path("gly.pqr").string(), "-o", off.string(), "--method", "trace",
           "--trace-degree", "12", "--trace-step", "0.25", "--trace-cos-bound", "0.95", "--trace-extreme-tolerance",
           "0.01", "--report", path("gly.json").string(), "--verbose"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("tracing"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("trace: "), std::string::npos) << result.err;
  const nlohmann::json report = nlohmann::json::parse(read_file(path("gly.json")));
  EXPECT_EQ(report.at("certificate").at("certified"), true);
  const nlohmann::json& parameters = report.at("trace").at("parameters");
  EXPECT_EQ(parameters.at("legendre_degree"), 12);
  EXPECT_EQ(parameters.at("step_fraction"), 0.25);
  EXPECT_EQ(parameters.at("cos_bound"), 0.95);
  EXPECT_EQ(parameters.at("extreme_tolerance"), 0.01);
}

TEST_F(TracemeshCli, OutputIsTheSameWhateverTheThreadCount) {
  // Glycine keeps this fast under sanitizers; core's own tests cover thread-independence on larger inputs.
  const std::string input = tracemesh::testing::molecule_path("gly.pqr").string();
  ASSERT_EQ(run({input, "-o", path("one.off").string(), "--threads", "1"}).exit_code, 0);
  ASSERT_EQ(run({input, "-o", path("two.off").string(), "--threads", "2"}).exit_code, 0);
  EXPECT_EQ(read_file(path("one.off")), read_file(path("two.off")));
}

TEST_F(TracemeshCli, FormatFromTheExtensionOrTheOption) {
  const std::string input = tracemesh::testing::molecule_path("gly.pqr").string();
  ASSERT_EQ(run({input, "-o", path("gly.drc").string()}).exit_code, 0);
  EXPECT_EQ(read_file(path("gly.drc")).rfind("DRACO", 0), 0U) << "Draco magic";
  ASSERT_EQ(run({input, "-o", path("gly.bin").string(), "--format", "draco"}).exit_code, 0);
  EXPECT_EQ(read_file(path("gly.bin")), read_file(path("gly.drc")));
  ASSERT_EQ(run({input, "-o", path("upper.OFF").string()}).exit_code, 0);
  EXPECT_TRUE(parse_off(read_file(path("upper.OFF"))).ok);
}

TEST_F(TracemeshCli, GlbAndPlyFromTheExtensionGlbRawFromTheOption) {
  const std::string input = tracemesh::testing::molecule_path("gly.pqr").string();
  ASSERT_EQ(run({input, "-o", path("gly.glb").string()}).exit_code, 0);
  const std::string glb = read_file(path("gly.glb"));
  EXPECT_EQ(glb.rfind("glTF", 0), 0U) << "GLB magic";
  EXPECT_NE(glb.find("KHR_draco_mesh_compression"), std::string::npos) << ".glb is the compressed GLB";
  ASSERT_EQ(run({input, "-o", path("raw.glb").string(), "--format", "glb-raw", "--report", path("raw.json").string()})
                .exit_code,
            0);
  const std::string raw = read_file(path("raw.glb"));
  EXPECT_EQ(raw.rfind("glTF", 0), 0U);
  EXPECT_EQ(raw.find("KHR_draco_mesh_compression"), std::string::npos);
  const nlohmann::json report = nlohmann::json::parse(read_file(path("raw.json")));
  EXPECT_EQ(report.at("encodings").at("glb-raw").at("bytes"), raw.size()) << "the report states the encoding";
  EXPECT_EQ(report.at("encodings").at("glb-raw").at("decoded_check").at("passed"), true);
  ASSERT_EQ(run({input, "-o", path("gly.ply").string(), "--report", path("ply.json").string()}).exit_code, 0);
  EXPECT_EQ(read_file(path("gly.ply")).rfind("ply\nformat binary_little_endian 1.0\n", 0), 0U);
  ASSERT_EQ(run({input, "-o", path("gly.drc").string(), "--report", path("drc.json").string()}).exit_code, 0);
  const nlohmann::json draco = nlohmann::json::parse(read_file(path("drc.json"))).at("encodings").at("draco");
  EXPECT_LE(draco.at("position_quantization").at("step").get<double>(), 0.01);
  EXPECT_EQ(draco.at("decoded_check").at("passed"), true);
}

TEST_F(TracemeshCli, MsmsPair) {
  const run_result result =
      run({tracemesh::testing::molecule_path("gly.pqr").string(), "-o", path("gly.vert").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::string vert = read_file(path("gly.vert")), face = read_file(path("gly.face"));
  std::istringstream vert_header(vert.substr(vert.find('\n', vert.find('\n') + 1) + 1));
  std::istringstream face_header(face.substr(face.find('\n', face.find('\n') + 1) + 1));
  std::size_t vertices = 0, triangles = 0;
  ASSERT_TRUE(vert_header >> vertices);
  ASSERT_TRUE(face_header >> triangles);
  EXPECT_EQ(line_count(vert), 3 + vertices);
  EXPECT_EQ(line_count(face), 3 + triangles);
  EXPECT_EQ(2 * vertices - 4, triangles) << "a closed genus-0 surface";
}

TEST_F(TracemeshCli, GzipInputGivesTheSameMesh) {
  const fs::path plain = tracemesh::testing::molecule_path("gly.pqr");
  const std::string gzip = "gzip -c " + shell_quote(plain.string()) + " > " + shell_quote(path("gly.pqr.gz").string());
  ASSERT_EQ(std::system(gzip.c_str()), 0);
  ASSERT_EQ(run({plain.string(), "-o", path("plain.off").string()}).exit_code, 0);
  const run_result result = run({path("gly.pqr.gz").string(), "-o", path("gzip.off").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(read_file(path("gzip.off")), read_file(path("plain.off")));
}

TEST_F(TracemeshCli, InterruptCancelsCleanly) {
  // SIGINT once the run shows it is meshing: its progress line, drawn because stderr is a terminal. The test
  // program holds the run at its first report of the root stage until the interrupt (support/held_run_hook.cpp),
  // so the signal lands in the middle of meshing however fast the machine: exit 130, one line, no output, no
  // temporary file.
  tracemesh::testing::terminal_child run(
      tracemesh::testing::binary_path("tracemesh_testable"),
      {tracemesh::testing::molecule_path("fas2.pqr").string(), "-o", path("fas2.off").string()},
      {std::string(tracemesh::testing::held_run_stage_variable) + "=roots"});
  ASSERT_TRUE(run.started());
  ASSERT_TRUE(run.wait_for("roots")) << "no progress line: " << run.output();
  run.signal(SIGINT);
  EXPECT_EQ(run.wait_exit(), 130) << run.output();
  // The progress line is erased ("\r\033[K") before the error is printed: what follows is the one line.
  const std::string& err = run.output();
  const std::string erase = "\r\033[K";
  const std::size_t erased = err.rfind(erase);
  ASSERT_NE(erased, std::string::npos) << err;
  const std::string last = err.substr(erased + erase.size());
  EXPECT_EQ(line_count(last), 1U) << err;
  EXPECT_EQ(last.rfind("tracemesh: ", 0), 0U) << err;
  EXPECT_NE(last.find("cancelled"), std::string::npos) << err;
  EXPECT_EQ(line_count(err), 1U) << "progress lines are redrawn in place, never ended: " << err;
  EXPECT_EQ(files(), std::vector<std::string>{});
}

TEST_F(TracemeshCli, VerbosePrintsTimingsOnStderr) {
  const run_result result = run({tracemesh::testing::molecule_path("gly.pqr").string(), "-o",
                                 path("gly.off").string(), "--verbose"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("culling"), std::string::npos) << result.err;  // a stage of either method
  EXPECT_NE(result.err.find("certified"), std::string::npos) << result.err;
}

}  // namespace
