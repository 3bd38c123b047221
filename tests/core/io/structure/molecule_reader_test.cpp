// Every input format of one real molecule (fas2) gives the same atoms and the same mesh (issue 11, item 5).
#include "core/io/structure/molecule_reader.hpp"

#include <gtest/gtest.h>

#include <string>

#include "core/io/pqr_reader.hpp"
#include "core/mesher.hpp"
#include "support/structure_writers.hpp"
#include "support/test_paths.hpp"
#include "support/text_files.hpp"

namespace tracemesh {
namespace {

using testing::gzip;

read_molecule_result read_ok(const std::string& bytes, const structure_options& options = {}) {
  result<read_molecule_result> read = read_molecule(bytes, options, mesh_limits{}, 1 << 26);
  EXPECT_TRUE(read.ok()) << read.error().message();
  return read.ok() ? *read : read_molecule_result{};
}

void expect_same_geometry(const molecule& a, const molecule& b, const char* what) {
  ASSERT_EQ(a.atoms.size(), b.atoms.size()) << what;
  for (std::size_t i = 0; i < a.atoms.size(); ++i) {
    ASSERT_EQ(a.atoms[i].center, b.atoms[i].center) << what << ", atom " << i;  // bitwise: one job id
    ASSERT_EQ(a.atoms[i].radius, b.atoms[i].radius) << what << ", atom " << i;
  }
}

TEST(MoleculeReader, EveryFormatOfFas2GivesTheSameAtomsAndMesh) {
  const auto atoms = testing::atoms_of_pqr(testing::read_file(testing::molecule_path("fas2.pqr")));
  ASSERT_EQ(atoms.size(), 906u);
  const read_molecule_result pqr = read_ok(testing::to_pqr(atoms, radii_set::bondi));
  EXPECT_EQ(pqr.format, input_format::pqr);

  const struct {
    const char* what;
    std::string bytes;
    input_format format;
  } others[] = {
      {"PDB", testing::to_pdb(atoms), input_format::pdb},
      {"PDB, gzip", gzip(testing::to_pdb(atoms)), input_format::pdb},
      {"mmCIF", testing::to_mmcif(atoms), input_format::mmcif},
      {"mmCIF, gzip", gzip(testing::to_mmcif(atoms)), input_format::mmcif},
      {"xyzr", testing::to_xyzr(atoms, radii_set::bondi), input_format::xyzr},
      // A UTF-8 byte order mark first: the PDB reader lost the first atom behind it, the mmCIF reader refused it.
      {"PDB, BOM", "\xEF\xBB\xBF" + testing::to_pdb(atoms), input_format::pdb},
      {"mmCIF, BOM", "\xEF\xBB\xBF" + testing::to_mmcif(atoms), input_format::mmcif},
      {"xyzr, BOM", "\xEF\xBB\xBF" + testing::to_xyzr(atoms, radii_set::bondi), input_format::xyzr},
  };
  for (const auto& other : others) {
    const read_molecule_result read = read_ok(other.bytes);
    EXPECT_EQ(read.format, other.format) << other.what;
    expect_same_geometry(pqr.mol, read.mol, other.what);
  }

  // The same atoms are the same mesh; checked once end to end on the PDB (fas2 meshes in a fraction of a second).
  progress_token progress;
  const result<mesh_output> from_pqr = mesh_molecule(pqr.mol, mesh_params{}, mesh_limits{}, progress);
  const result<mesh_output> from_pdb =
      mesh_molecule(read_ok(testing::to_pdb(atoms)).mol, mesh_params{}, mesh_limits{}, progress);
  ASSERT_TRUE(from_pqr.ok() && from_pdb.ok());
  EXPECT_TRUE(from_pdb->certified);
  EXPECT_NEAR(from_pdb->report.area, from_pqr->report.area, 1e-9 * from_pqr->report.area);
  EXPECT_EQ(from_pdb->report.vertices, from_pqr->report.vertices);

  // Another radii set is another molecule.
  structure_options mantina;
  mantina.radii = radii_set::mantina;
  expect_same_geometry(read_ok(testing::to_pqr(atoms, radii_set::mantina)).mol,
                       read_ok(testing::to_pdb(atoms), mantina).mol, "PDB, mantina");
}

TEST(MoleculeReader, ReadsFilesOfEveryFormat) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "tracemesh_molecule_reader_test";
  std::filesystem::create_directories(dir);
  const auto atoms = testing::atoms_of_pqr(testing::read_file(testing::molecule_path("gly.pqr")));
  std::ofstream(dir / "gly.cif.gz", std::ios::binary) << gzip(testing::to_mmcif(atoms));
  result<read_molecule_result> read = read_molecule_file(dir / "gly.cif.gz", {});
  ASSERT_TRUE(read.ok()) << read.error().message();
  EXPECT_EQ(read->format, input_format::mmcif);
  EXPECT_EQ(read->mol.atoms.size(), 7u);
  result<read_molecule_result> pqr = read_molecule_file(testing::molecule_path("gly.pqr"), {});
  ASSERT_TRUE(pqr.ok());
  EXPECT_EQ(pqr->mol.atoms[0].radius, 1.824) << "PQR keeps its own radii whatever the options";
  EXPECT_EQ(read_molecule_file(dir / "absent.pdb", {}).error().code(), errc::io_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tracemesh
