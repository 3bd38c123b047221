// Every molecule of the shared ladder up to ~35k atoms, at densities 1 and 2, by both paths (trace and lattice, each
// with the quality pass): the mesh must carry the certificate (closed, oriented, manifold, no self-intersection,
// vertices on the surface) and meet the quality targets.
#include <gtest/gtest.h>

#include <cstdlib>
#include <ostream>
#include <string>
#include <tuple>

#include "core/mesher.hpp"
#include "core/io/pqr_reader.hpp"
#include "support/mesh_expectations.hpp"
#include "support/sanitized_build.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

using testing::case_name;
using testing::ladder_case;
using testing::sanitized_build;

/// Meshes `mol` with default parameters but `density`, `method` and `threads` (0: all), expecting success.
result<mesh_output> mesh_at(const molecule& mol, double density, mesh_method method = mesh_params{}.method,
                            unsigned threads = 0) {
  mesh_params params;
  params.density = density;
  params.method = method;
  params.threads = threads;
  progress_token progress;
  auto out = mesh_molecule(mol, params, {}, progress);
  EXPECT_TRUE(out.ok()) << out.error().message();
  return out;
}

using ladder_run = std::tuple<ladder_case, mesh_method>;

std::string run_name(const ::testing::TestParamInfo<ladder_run>& info) {
  const auto& [c, method] = info.param;
  return case_name(::testing::TestParamInfo<ladder_case>(c, info.index)) + "_" + method_name(method);
}

class molecule_ladder : public ::testing::TestWithParam<ladder_run> {};

TEST_P(molecule_ladder, mesh_is_certified_and_well_shaped) {
  const auto& [c, method] = GetParam();
  auto mol = read_pqr_file(testing::molecule_path(c.file));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  if (sanitized_build() && mol->atoms.size() > 10000) GTEST_SKIP() << "large molecules run in the Release suite only";
  auto out = mesh_at(*mol, c.density, method);
  ASSERT_TRUE(out.ok());
  const mesh_report& r = out->report;
  testing::expect_certified_output(*out);
  if (method == mesh_method::trace) {
    EXPECT_EQ(r.folded_triangles, 0u);  // issue 34: a boundary-element solver stalls on folds
  }
  EXPECT_GT(r.volume, 0);
  EXPECT_NEAR(r.achieved_density, c.density, 0.2 * c.density);
  EXPECT_GE(r.quality.edge_ratio_mean, 0.70);
  EXPECT_LT(r.quality.fraction_below_0_2, 0.01);
  if (method == mesh_method::trace) {
    // Issue 10's target. 1ihm_asu at 1 v/Å² has a cavity 0.16 Å across, whose 4 vertices are 0.094 × the median
    // edge apart at least; no 4 points of its surface are further apart than 0.095 × (remesh_small_components.hpp).
    const bool tiny_cavity = c.file == "1ihm_asu.pqr" && c.density == 1;
    EXPECT_GE(r.quality.shortest_edge, (tiny_cavity ? 0.09 : 0.1) * r.quality.median_edge);
  }
}

INSTANTIATE_TEST_SUITE_P(
    ladder, molecule_ladder,
    ::testing::Combine(
        ::testing::Values(ladder_case{"gly.pqr", 1}, ladder_case{"gly.pqr", 2}, ladder_case{"adp.pqr", 1},
                          ladder_case{"adp.pqr", 2}, ladder_case{"villin_1vii.pqr", 1},
                          ladder_case{"villin_1vii.pqr", 2}, ladder_case{"fas2.pqr", 1}, ladder_case{"fas2.pqr", 2},
                          ladder_case{"mache.pqr", 1}, ladder_case{"mache.pqr", 2}, ladder_case{"achbp.pqr", 1},
                          ladder_case{"achbp.pqr", 2}, ladder_case{"3j6r_asu.pqr", 1}, ladder_case{"3j6r_asu.pqr", 2},
                          ladder_case{"1ihm_asu.pqr", 1}, ladder_case{"1ihm_asu.pqr", 2},
                          ladder_case{"2buk_12asu.pqr", 1}, ladder_case{"2buk_12asu.pqr", 2}),
        ::testing::Values(mesh_method::trace, mesh_method::lattice)),
    run_name);

// mache at density 1 is large enough to be remeshed in chunks (remesh_chunks.hpp): patches run on whichever
// thread is free, yet the mesh must not depend on the thread count (the service's cache keys on it).
TEST(mesh_determinism, chunked_molecule_is_identical_whatever_the_thread_count) {
  auto mol = read_pqr_file(testing::molecule_path("mache.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  for (const mesh_method method : {mesh_method::trace, mesh_method::lattice}) {
    SCOPED_TRACE(method_name(method));
    const auto run = [&](unsigned threads) {
      auto out = mesh_at(*mol, 1.0, method, threads);
      return out.ok() ? std::move(out->mesh) : surface_mesh{};
    };
    const surface_mesh one = run(1), two = run(2);
    ASSERT_GT(one.triangles.size(), 30000u);
    EXPECT_EQ(one.positions, two.positions);  // bitwise
    EXPECT_EQ(one.triangles, two.triangles);
    EXPECT_EQ(one.normals, two.normals);
    EXPECT_EQ(one.atom_index, two.atom_index);
  }
}

// Area and volume converge to a much finer reference as the density grows (fas2, 906 atoms).
TEST(mesh_convergence, area_and_volume_approach_a_fine_reference) {
  auto mol = read_pqr_file(testing::molecule_path("fas2.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  const auto measure = [&](double density) {
    auto out = mesh_at(*mol, density);
    return out.ok() ? std::pair{out->report.area, out->report.volume} : std::pair{0.0, 0.0};
  };
  const auto [reference_area, reference_volume] = measure(8.0);
  const auto [area1, volume1] = measure(1.0);
  const auto [area2, volume2] = measure(2.0);
  const double area_error1 = std::abs(area1 - reference_area) / reference_area;
  const double area_error2 = std::abs(area2 - reference_area) / reference_area;
  const double volume_error2 = std::abs(volume2 - reference_volume) / reference_volume;
  EXPECT_LT(area_error2, 0.02);
  EXPECT_LT(volume_error2, 0.01);
  EXPECT_LT(area_error2, area_error1);
}

}  // namespace
}  // namespace tracemesh
