// cavities=keep|drop on a real molecule with inner voids: mache (acetylcholinesterase, 8,279 atoms) has about ten
// cavities at density 1. Lattice path without the quality pass, to keep the two runs quick.
#include <gtest/gtest.h>

#include "core/io/pqr_reader.hpp"
#include "core/mesher.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

TEST(Cavities, MacheDropRemovesEveryEnclosedComponentAndStaysCertified) {
  auto mol = read_pqr_file(testing::molecule_path("mache.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  mesh_params params;
  params.refine = refine_mode::none;
  progress_token token;
  auto kept = mesh_molecule(*mol, params, {}, token);
  ASSERT_TRUE(kept.ok()) << kept.error().message();
  std::size_t enclosed = 0;
  double enclosed_volume = 0;
  for (const component_report& component : kept->report.components) {
    if (!component.enclosed) continue;
    ++enclosed;
    enclosed_volume += component.volume;
    EXPECT_NE(&component, &kept->report.components.front()) << "the largest surface is the outer one";
  }
  EXPECT_GE(kept->report.cavities, 5u) << "mache has inner voids at density 1";
  EXPECT_GE(enclosed, kept->report.cavities) << "every cavity is enclosed";

  params.cavities = cavity_mode::drop;
  auto dropped = mesh_molecule(*mol, params, {}, token);
  ASSERT_TRUE(dropped.ok()) << dropped.error().message();
  EXPECT_TRUE(dropped->certified);
  EXPECT_EQ(dropped->dropped_components, enclosed);
  EXPECT_EQ(dropped->report.components.size(), kept->report.components.size() - enclosed);
  EXPECT_EQ(dropped->report.cavities, 0u);
  for (const component_report& component : dropped->report.components) EXPECT_FALSE(component.enclosed);
  // The volume enclosed by what is left is the kept volume without the cavities (and islands).
  EXPECT_NEAR(dropped->report.volume, kept->report.volume - enclosed_volume, 1e-6 * kept->report.volume);
  EXPECT_GT(dropped->report.volume, kept->report.volume);
}

}  // namespace
}  // namespace tracemesh
