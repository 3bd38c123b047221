// Real molecules meshed by tracemesh::mesh_molecule, certified independently by CGAL (tests only): closed,
// oriented 2-manifold, no self-intersection, bounds a volume with cavities pointing into themselves, and the same
// component count, area and volume as tracemesh's own analysis.
#include <gtest/gtest.h>

#include <cstdlib>
#include <ostream>
#include <string>

#include "cgal/cgal_check.hpp"
#include "core/mesher.hpp"
#include "core/io/pqr_reader.hpp"
#include "support/sanitized_build.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

struct molecule_case {
  std::string file;
  double density;
};

void PrintTo(const molecule_case& c, std::ostream* os) { *os << c.file << " at density " << c.density; }

class cgal_molecule_certificate : public ::testing::TestWithParam<molecule_case> {};

TEST_P(cgal_molecule_certificate, cgal_agrees_the_mesh_is_certified) {
  const molecule_case& c = GetParam();
  auto mol = read_pqr_file(testing::molecule_path(c.file));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  if (testing::sanitized_build() && mol->atoms.size() > 1000) GTEST_SKIP() << "Release suite only";
  mesh_params params;
  params.density = c.density;
  progress_token progress;
  auto out = mesh_molecule(*mol, params, {}, progress);
  ASSERT_TRUE(out.ok()) << out.error().message();
  const testing::cgal_certificate cgal = testing::check_with_cgal(out->mesh);
  EXPECT_TRUE(cgal.certified()) << testing::describe(cgal);
  EXPECT_EQ(cgal.components, out->report.components.size());
  EXPECT_NEAR(cgal.area, out->report.area, 1e-6 * out->report.area);
  EXPECT_NEAR(cgal.volume, out->report.volume, 1e-6 * std::abs(out->report.volume));
  std::size_t cgal_cavities = 0;
  for (const auto& component : cgal.component_details) cgal_cavities += component.nesting_level % 2;
  EXPECT_EQ(cgal_cavities, out->report.cavities);
}

INSTANTIATE_TEST_SUITE_P(molecules, cgal_molecule_certificate,
                         ::testing::Values(molecule_case{"gly.pqr", 1}, molecule_case{"gly.pqr", 2},
                                           molecule_case{"adp.pqr", 1}, molecule_case{"adp.pqr", 2},
                                           molecule_case{"villin_1vii.pqr", 1}, molecule_case{"fas2.pqr", 1},
                                           molecule_case{"fas2.pqr", 2}, molecule_case{"mache.pqr", 1}),
                         [](const ::testing::TestParamInfo<molecule_case>& info) {
                           return info.param.file.substr(0, info.param.file.find('.')) + "_density_" +
                                  std::to_string(static_cast<int>(info.param.density));
                         });

}  // namespace
}  // namespace tracemesh
