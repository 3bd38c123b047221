// Black-box tests of `tracemesh nanoshaper` and of tracemesh invoked as NanoShaper: the real binary, run the way
// TABI-PB and APBS's BEM path run NanoShaper (molecule.xyzr and surfaceConfiguration.prm in an empty working
// directory, no argument), and the files read back as those clients read them, then checked by the certificate.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "core/io/pqr_reader.hpp"
#include "core/mesh.hpp"
#include "support/mesh_expectations.hpp"
#include "support/test_paths.hpp"
#include "support/text_files.hpp"

// A named namespace around the anonymous one: the unity build compiles this file with main_test.cpp.
namespace nanoshaper_command_test {
namespace {

namespace fs = std::filesystem;
using tracemesh::testing::read_file;
using tracemesh::testing::shell_quote;

struct run_result {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// The keys TABI-PB (and APBS's copy of its mesher) write before running NanoShaper; `surface` is ses or skin.
std::string tabi_prm(const std::string& surface, double grid_scale) {
  char scale[32];
  std::snprintf(scale, sizeof scale, "%f", grid_scale);
  return std::string("Grid_scale = ") + scale +
         "\nGrid_perfil = 90.000000\nXYZR_FileName = molecule.xyzr\nBuild_epsilon_maps = false\n"
         "Build_status_map = false\nSave_Mesh_MSMS_Format = true\nCompute_Vertex_Normals = true\nSurface = " +
         surface +
         "\nSmooth_Mesh = true\nSkin_Surface_Parameter = 0.450000\nCavity_Detection_Filling = false\n"
         "Conditional_Volume_Filling_Value = 11.400000\nKeep_Water_Shaped_Cavities = false\n"
         "Probe_Radius = 1.400000\nAccurate_Triangulation = true\nTriangulation = true\n"
         "Check_duplicated_vertices = true\nSave_Status_map = false\nSave_PovRay = false\n";
}

/// A molecule of the ladder as xyzr text (every atom, radius-0 ones included: the reader accepts them).
std::string xyzr_of(const std::string& pqr) {
  const tracemesh::result<tracemesh::molecule> mol = tracemesh::read_pqr_file(tracemesh::testing::molecule_path(pqr));
  EXPECT_TRUE(mol.ok()) << mol.error().message();
  std::string text;
  if (!mol) return text;
  char line[128];
  for (const tracemesh::atom& a : mol->atoms) {
    std::snprintf(line, sizeof line, "%.3f %.3f %.3f %.3f\n", a.center.x, a.center.y, a.center.z, a.radius);
    text += line;
  }
  return text;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> fields_of(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> fields;
  for (std::string field; in >> field;) fields.push_back(field);
  return fields;
}

/// The three header lines the clients skip or read: two lines (TABI-PB skips them to their newline), then the count
/// alone (TABI-PB reads it with one "%d"; anything after it would be read as the first vertex's x); then exactly
/// `count` body lines, none blank, each with `fields` numbers.
std::vector<std::vector<std::string>> checked_body(const std::string& text, std::size_t fields) {
  const std::vector<std::string> lines = lines_of(text);
  EXPECT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  if (lines.size() < 3) {
    ADD_FAILURE() << "fewer than 3 lines";
    return {};
  }
  const std::vector<std::string> count_line = fields_of(lines[2]);
  EXPECT_EQ(count_line.size(), 1U) << "line 3: '" << lines[2] << "'";
  const std::size_t count = count_line.empty() ? 0 : std::stoul(count_line[0]);
  EXPECT_EQ(lines.size(), 3 + count);
  std::vector<std::vector<std::string>> body;
  for (std::size_t i = 3; i < lines.size(); ++i) {
    body.push_back(fields_of(lines[i]));
    EXPECT_EQ(body.back().size(), fields) << "line " << i + 1 << ": '" << lines[i] << "'";
  }
  return body;
}

/// The mesh as TABI-PB reads triangulatedSurf.vert/.face, every format rule checked on the way: vertices with unit
/// normals, 1-based indices within range.
tracemesh::surface_mesh read_msms_pair(const fs::path& vert, const fs::path& face) {
  tracemesh::surface_mesh mesh;
  for (const std::vector<std::string>& v : checked_body(read_file(vert), 9)) {
    if (v.size() != 9) continue;
    mesh.positions.push_back({std::stod(v[0]), std::stod(v[1]), std::stod(v[2])});
    const tracemesh::vec3 n{std::stod(v[3]), std::stod(v[4]), std::stod(v[5])};
    EXPECT_NEAR(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z), 1.0, 1e-5);
    mesh.normals.push_back(n);
  }
  const std::size_t n = mesh.positions.size();
  for (const std::vector<std::string>& f : checked_body(read_file(face), 5)) {
    if (f.size() != 5) continue;
    const std::uint32_t a = std::stoul(f[0]), b = std::stoul(f[1]), c = std::stoul(f[2]);
    EXPECT_TRUE(a >= 1 && a <= n && b >= 1 && b <= n && c >= 1 && c <= n) << a << " " << b << " " << c;
    if (a >= 1 && a <= n && b >= 1 && b <= n && c >= 1 && c <= n) mesh.triangles.push_back({a - 1, b - 1, c - 1});
  }
  return mesh;
}

/// Normals point outward: each vertex normal agrees with the area-weighted normal of its triangles (which the
/// certificate orients outward).
void expect_outward_normals(const tracemesh::surface_mesh& mesh) {
  std::vector<tracemesh::vec3> from_triangles(mesh.vertex_count());
  for (const auto& t : mesh.triangles) {
    const tracemesh::vec3 normal =
        cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
    for (const std::uint32_t v : t) from_triangles[v] = from_triangles[v] + normal;
  }
  std::size_t inward = 0;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) inward += dot(from_triangles[i], mesh.normals[i]) <= 0;
  EXPECT_EQ(inward, 0U);
}

void expect_certified(const tracemesh::surface_mesh& mesh) {
  ASSERT_GT(mesh.triangle_count(), 100U);
  tracemesh::testing::expect_certified_report(tracemesh::analyze_mesh(mesh));
  expect_outward_normals(mesh);
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t count = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++count;
  return count;
}

/// A scratch working directory per test, removed afterwards.
class NanoShaperCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("tracemesh_nanoshaper_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path path(const std::string& name) const { return dir_ / name; }
  void write(const std::string& name, const std::string& content) const {
    fs::create_directories(path(name).parent_path());
    std::ofstream(path(name), std::ios::binary) << content;
  }

  /// Runs `command` (already quoted) in the working directory, as std::system("NanoShaper") does.
  run_result run_in_directory(const std::string& command) const {
    const std::string line = "cd " + shell_quote(dir_.string()) + " && " + command + " < /dev/null > " +
                             shell_quote(path(".stdout").string()) + " 2> " + shell_quote(path(".stderr").string());
    const int raw = std::system(line.c_str());
    run_result result;
    result.exit_code = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    result.out = read_file(path(".stdout"));
    result.err = read_file(path(".stderr"));
    fs::remove(path(".stdout"));
    fs::remove(path(".stderr"));
    return result;
  }

  /// `tracemesh nanoshaper ARGS...`.
  run_result run(const std::vector<std::string>& args = {}) const {
    std::string command = shell_quote(tracemesh::testing::binary_path("tracemesh").string()) + " nanoshaper";
    for (const std::string& arg : args) {
      command += ' ';
      command += shell_quote(arg);
    }
    return run_in_directory(command);
  }

  /// `NanoShaper`, found on PATH as a link to tracemesh, exactly as TABI-PB's std::system("NanoShaper") finds it.
  run_result run_as_nanoshaper() const {
    fs::create_directories(path("bin"));
    fs::create_symlink(tracemesh::testing::binary_path("tracemesh"), path("bin/NanoShaper"));
    return run_in_directory("PATH=" + shell_quote(path("bin").string()) + ":\"$PATH\" NanoShaper");
  }

  /// Exit 1, exactly one stderr line "tracemesh: ..." mentioning `mentions`, no mesh file.
  void expect_failure(const run_result& result, const std::string& mentions) const {
    EXPECT_EQ(result.exit_code, 1) << result.err;
    EXPECT_EQ(count_of(result.err, "\n"), 1U) << result.err;
    EXPECT_EQ(result.err.rfind("tracemesh: ", 0), 0U) << result.err;
    EXPECT_NE(result.err.find(mentions), std::string::npos) << result.err;
    for (const char* name : {"triangulatedSurf.vert", "triangulatedSurf.face", "triangulatedSurf.off"}) {
      EXPECT_FALSE(fs::exists(path(name))) << name;
    }
  }

  fs::path dir_;
};

TEST_F(NanoShaperCommand, TabiPbSesRunWritesACertifiedMsmsPairWithNanoShapersHeader) {
  write("molecule.xyzr", xyzr_of("fas2.pqr"));
  write("surfaceConfiguration.prm", tabi_prm("ses", 1.0));
  const run_result result = run();
  ASSERT_EQ(result.exit_code, 0) << result.err;
  // The substitution is said once; TABI-PB's keys are all known, so nothing else is said.
  EXPECT_EQ(count_of(result.err, "\n"), 1U) << result.err;
  EXPECT_NE(result.err.find("Surface = ses"), std::string::npos) << result.err;
  EXPECT_EQ(count_of(result.err, "Gaussian surface"), 1U) << result.err;
  const tracemesh::surface_mesh mesh = read_msms_pair(path("triangulatedSurf.vert"), path("triangulatedSurf.face"));
  expect_certified(mesh);
  EXPECT_NE(result.out.find(std::to_string(mesh.vertex_count()) + " vertices"), std::string::npos) << result.out;
}

TEST_F(NanoShaperCommand, ApbsSkinRunThroughALinkNamedNanoShaperOnPath) {
  write("molecule.xyzr", xyzr_of("adp.pqr"));
  write("surfaceConfiguration.prm", tabi_prm("skin", 2.0));
  const run_result result = run_as_nanoshaper();
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("Surface = skin"), std::string::npos) << result.err;
  expect_certified(read_msms_pair(path("triangulatedSurf.vert"), path("triangulatedSurf.face")));
}

TEST_F(NanoShaperCommand, GridScaleSetsTheVertexDensityAsTheSquare) {
  write("molecule.xyzr", xyzr_of("fas2.pqr"));
  std::size_t vertices[2] = {0, 0};
  for (const int i : {0, 1}) {
    write("surfaceConfiguration.prm", tabi_prm("ses", i == 0 ? 0.8 : 1.6));
    ASSERT_EQ(run().exit_code, 0);
    vertices[i] = read_msms_pair(path("triangulatedSurf.vert"), path("triangulatedSurf.face")).vertex_count();
  }
  const double ratio = static_cast<double>(vertices[1]) / static_cast<double>(vertices[0]);
  EXPECT_GT(ratio, 3.0) << vertices[0] << " → " << vertices[1]
                        << ": twice the Grid_scale, about four times the vertices";
  EXPECT_LT(ratio, 5.0) << vertices[0] << " → " << vertices[1];
}

TEST_F(NanoShaperCommand, BlobbyWithoutMsmsKeyWritesOffWithNormalsAndTheBlobbynessIsItsDecay) {
  write("molecule.xyzr", xyzr_of("adp.pqr"));
  const std::string keys = "Surface = blobby\nXYZR_FileName = molecule.xyzr\nGrid_scale = 1.0\n"
                           "Compute_Vertex_Normals = true\n";
  double volumes[2] = {0, 0};
  for (const int i : {0, 1}) {
    write("conf.prm", keys + (i == 0 ? "Blobbyness = -1\n" : "Blobbyness = -4\n"));
    const run_result result = run({"conf.prm"});
    ASSERT_EQ(result.exit_code, 0) << result.err;
    EXPECT_TRUE(result.err.empty()) << result.err;
    const std::vector<std::string> lines = lines_of(read_file(path("triangulatedSurf.off")));
    ASSERT_GT(lines.size(), 2U);
    EXPECT_EQ(lines[0], "OFF+N");
    const std::vector<std::string> counts = fields_of(lines[1]);
    ASSERT_EQ(counts.size(), 3U);
    const std::size_t vertices = std::stoul(counts[0]), triangles = std::stoul(counts[1]);
    ASSERT_EQ(lines.size(), 2 + vertices + triangles);
    EXPECT_EQ(fields_of(lines[2]).size(), 6U) << "x y z nx ny nz";
    EXPECT_EQ(fields_of(lines.back()).size(), 4U) << "3 a b c";
    const std::size_t at = result.out.find("volume ");
    ASSERT_NE(at, std::string::npos) << result.out;
    volumes[i] = std::stod(result.out.substr(at + 7));
  }
  EXPECT_GT(volumes[0], volumes[1] * 1.2) << "a slower decay (d = -1) makes a fuller surface than d = -4";
}

TEST_F(NanoShaperCommand, PlyWhenTheConfigurationAsksForIt) {
  write("molecule.xyzr", xyzr_of("adp.pqr"));
  write("surfaceConfiguration.prm", tabi_prm("ses", 1.0) + "Save_Mesh_PLY_Format = true\n");
  ASSERT_EQ(run().exit_code, 0);
  EXPECT_EQ(read_file(path("triangulatedSurf.ply")).rfind("ply\nformat binary_little_endian 1.0\n", 0), 0U);
  EXPECT_FALSE(fs::exists(path("triangulatedSurf.vert"))) << "PLY wins over MSMS, as in NanoShaper";
}

TEST_F(NanoShaperCommand, RootFileNameAndOutputFolderPlaceTheFilesAndTheXyzrIsReadThere) {
  write("out/molecule.xyzr", xyzr_of("adp.pqr"));
  write("surfaceConfiguration.prm", tabi_prm("ses", 1.0) + "Root_FileName = ns_\nOutput_Folder = out\n");
  ASSERT_EQ(run().exit_code, 0);
  expect_certified(read_msms_pair(path("out/ns_triangulatedSurf.vert"), path("out/ns_triangulatedSurf.face")));
}

TEST_F(NanoShaperCommand, MissingBlobbynessIsWarnedAboutAndNanoShapersDefaultUsed) {
  write("molecule.xyzr", xyzr_of("adp.pqr"));
  write("surfaceConfiguration.prm",
        "Surface = blobby\nBlobyness = -1\nXYZR_FileName = molecule.xyzr\nGrid_scale = 1\nSave_Mesh_MSMS_Format = 1\n");
  const run_result result = run();
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(count_of(result.err, "\n"), 2U) << result.err;
  EXPECT_NE(result.err.find("line 2: unknown key Blobyness"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("without Blobbyness: using NanoShaper's default -2.5"), std::string::npos) << result.err;
  expect_certified(read_msms_pair(path("triangulatedSurf.vert"), path("triangulatedSurf.face")));
}

TEST_F(NanoShaperCommand, UnknownAndUnsupportedKeysAreNamedOneLineEach) {
  write("molecule.xyzr", xyzr_of("adp.pqr"));
  write("surfaceConfiguration.prm",
        tabi_prm("ses", 1.0) + "Grid_perfill = 70\nSave_Cavities = true\nSave_bgps = no\nGrid_perfil = 80\n");
  const run_result result = run();
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(count_of(result.err, "\n"), 4U) << result.err;  // three keys, the substitution
  EXPECT_NE(result.err.find("line 23: Grid_perfil repeated; line 2's value is replaced"), std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("line 20: unknown key Grid_perfill"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("line 21: Save_Cavities = true is not supported"), std::string::npos) << result.err;
}

TEST_F(NanoShaperCommand, MalformedConfigurationsFailWithOneLineAndNoFiles) {
  write("molecule.xyzr", xyzr_of("gly.pqr"));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"Grid_scale = 1\nSurface ses\n", "line 2: expected Key = value"},
      {"= 1\n", "line 1: no key before '='"},
      {"Grid_scale = fine\n", "line 1: Grid_scale: expected a number"},
      {"Grid_scale = 0\n", "Grid_scale: must be > 0"},
      {"Save_Mesh_MSMS_Format = maybe\n", "expected true or false"},
      {"Surface = mesh\n", "line 1: Surface: 'mesh' is not a molecular surface"},
      {"Surface = blobby\nBlobbyness = 0.5\n", "line 2: Blobbyness: must be in [-20, -0.05]"},
      {"Operative_Mode = pockets\n", "Operative_Mode: only normal"},
      {std::string("Grid_scale = 1\0\n", 16), "line 1: control byte"},
  };
  for (const auto& [text, message] : cases) {
    write("surfaceConfiguration.prm", text + "XYZR_FileName = molecule.xyzr # a comment\n\n");
    SCOPED_TRACE(text);
    expect_failure(run(), message);
  }
}

TEST_F(NanoShaperCommand, MissingFilesFailWithOneLineAndAnEarlierMeshIsRemoved) {
  write("triangulatedSurf.vert", "an earlier run's mesh\n");
  write("triangulatedSurf.face", "an earlier run's mesh\n");
  write("surfaceConfiguration.prm", tabi_prm("ses", 1.0));
  expect_failure(run(), "XYZR_FileName molecule.xyzr");  // TABI-PB would otherwise read the old mesh
  expect_failure(run({"absent.prm"}), "cannot read absent.prm");
  write("molecule.xyzr", "1 2 3\n");
  expect_failure(run(), "line 1");
}

TEST_F(NanoShaperCommand, UsageAndHelp) {
  const run_result help = run({"--help"});
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("Usage: tracemesh nanoshaper [CONF.prm]"), std::string::npos) << help.out;
  const run_result two = run({"a.prm", "b.prm"});
  EXPECT_EQ(two.exit_code, 2);
  EXPECT_EQ(count_of(two.err, "\n"), 1U) << two.err;
}

}  // namespace
}  // namespace nanoshaper_command_test
