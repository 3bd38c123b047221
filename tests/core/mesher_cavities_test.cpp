// cavities=keep|drop through mesh_molecule: a synthetic hollow shell of atoms with one atom at its centre (outer
// surface, inner cavity, and an island inside the cavity) meshed by both methods.
#include <gtest/gtest.h>

#include "core/mesher.hpp"
#include "support/shell_molecule.hpp"

namespace tracemesh {
namespace {

using testing::shell_with_island;

struct counted {
  std::size_t components = 0, enclosed = 0, cavities = 0;
};

counted count(const mesh_report& report) {
  counted c;
  c.components = report.components.size();
  for (const component_report& component : report.components) {
    c.enclosed += component.enclosed ? 1 : 0;
    c.cavities += component.cavity ? 1 : 0;
  }
  return c;
}

class MesherCavities : public ::testing::TestWithParam<mesh_method> {};

TEST_P(MesherCavities, DropRemovesTheCavityAndTheIslandAndKeepsACertifiedOuterSurface) {
  const molecule mol = shell_with_island();
  mesh_params params;
  params.method = GetParam();
  progress_token token;
  auto kept = mesh_molecule(mol, params, mesh_limits{}, token);
  ASSERT_TRUE(kept.ok()) << kept.error().message();
  const counted k = count(kept->report);
  ASSERT_EQ(k.components, 3u) << "outer surface, cavity, island";
  EXPECT_EQ(k.cavities, 1u);
  EXPECT_EQ(k.enclosed, 2u) << "the cavity and the island in it";
  EXPECT_FALSE(kept->report.components[0].enclosed) << "the largest (outer) surface";
  EXPECT_EQ(kept->dropped_components, 0u);
  EXPECT_EQ(kept->cavities, cavity_mode::keep);

  params.cavities = cavity_mode::drop;
  auto dropped = mesh_molecule(mol, params, mesh_limits{}, token);
  ASSERT_TRUE(dropped.ok()) << dropped.error().message();
  EXPECT_TRUE(dropped->certified);
  const counted d = count(dropped->report);
  EXPECT_EQ(d.components, 1u);
  EXPECT_EQ(d.enclosed, 0u);
  EXPECT_EQ(d.cavities, 0u);
  EXPECT_EQ(dropped->dropped_components, 2u);
  EXPECT_EQ(dropped->cavities, cavity_mode::drop);
  // The outer surface is the same surface either way; the kept mesh's volume subtracts the cavity and adds the
  // island.
  const component_report& outer_kept = kept->report.components[0];
  const component_report& outer_dropped = dropped->report.components[0];
  EXPECT_EQ(outer_dropped.vertices, outer_kept.vertices);
  EXPECT_EQ(outer_dropped.triangles, outer_kept.triangles);
  EXPECT_DOUBLE_EQ(outer_dropped.area, outer_kept.area);
  EXPECT_NEAR(dropped->report.volume, outer_kept.volume, 1e-6 * outer_kept.volume);
  EXPECT_LT(kept->report.volume, dropped->report.volume);
  EXPECT_EQ(dropped->report.vertices + kept->report.components[1].vertices + kept->report.components[2].vertices,
            kept->report.vertices);
  EXPECT_EQ(dropped->dropped_triangles, kept->report.triangles - dropped->report.triangles);
  EXPECT_EQ(dropped->mesh.normals.size(), dropped->mesh.vertex_count());
  EXPECT_EQ(dropped->mesh.atom_index.size(), dropped->mesh.vertex_count());
}

TEST(MesherCavitiesNames, ParseAndNameRoundTrip) {
  cavity_mode mode = cavity_mode::keep;
  EXPECT_TRUE(parse_cavity_mode("drop", mode));
  EXPECT_EQ(mode, cavity_mode::drop);
  EXPECT_STREQ(cavity_mode_name(mode), "drop");
  EXPECT_FALSE(parse_cavity_mode("Drop", mode));
  EXPECT_EQ(mode, cavity_mode::drop);
  EXPECT_TRUE(parse_cavity_mode("keep", mode));
  EXPECT_STREQ(cavity_mode_name(mode), "keep");
}

INSTANTIATE_TEST_SUITE_P(Methods, MesherCavities, ::testing::Values(mesh_method::lattice, mesh_method::trace),
                         [](const auto& info) { return std::string(method_name(info.param)); });

}  // namespace
}  // namespace tracemesh
