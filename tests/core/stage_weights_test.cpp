#include "core/stage_weights.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "core/io/pqr_reader.hpp"
#include "support/test_paths.hpp"

namespace tracemesh {
namespace {

constexpr std::array<std::pair<mesh_method, refine_mode>, 4> paths = {
    std::pair{mesh_method::lattice, refine_mode::full}, std::pair{mesh_method::lattice, refine_mode::none},
    std::pair{mesh_method::trace, refine_mode::full}, std::pair{mesh_method::trace, refine_mode::none}};

double share(mesh_method method, refine_mode refine, mesh_stage stage) {
  return stage_weights(method, refine)[static_cast<std::size_t>(stage)];
}

TEST(StageWeights, EveryPathsSharesAreNonNegativeAndSumToOne) {
  for (const auto& [method, refine] : paths) {
    double total = 0;
    for (const double s : stage_weights(method, refine)) {
      EXPECT_GE(s, 0.0);
      total += s;
    }
    EXPECT_NEAR(total, 1.0, 1e-12) << method_name(method) << " " << refine_name(refine);
  }
}

TEST(StageWeights, StagesAPathDoesNotRunHaveNoShareAndTheOnesItRunsHaveOne) {
  EXPECT_EQ(share(mesh_method::lattice, refine_mode::full, mesh_stage::tracing), 0.0);
  EXPECT_EQ(share(mesh_method::trace, refine_mode::full, mesh_stage::sampling), 0.0);
  EXPECT_EQ(share(mesh_method::trace, refine_mode::none, mesh_stage::refining), 0.0);
  EXPECT_EQ(share(mesh_method::lattice, refine_mode::none, mesh_stage::refining), 0.0);
  EXPECT_GT(share(mesh_method::lattice, refine_mode::full, mesh_stage::sampling), 0.0);
  EXPECT_GT(share(mesh_method::trace, refine_mode::none, mesh_stage::tracing), 0.0);
  // The measurement's main finding: the quality pass is most of a refined run.
  EXPECT_GT(share(mesh_method::lattice, refine_mode::full, mesh_stage::refining), 0.4);
  // Without the quality pass, the lattice path's other stages keep their proportions.
  const double ratio_full = share(mesh_method::lattice, refine_mode::full, mesh_stage::sampling) /
                            share(mesh_method::lattice, refine_mode::full, mesh_stage::certifying);
  const double ratio_none = share(mesh_method::lattice, refine_mode::none, mesh_stage::sampling) /
                            share(mesh_method::lattice, refine_mode::none, mesh_stage::certifying);
  EXPECT_NEAR(ratio_full, ratio_none, 1e-9);
}

TEST(StageWeights, OverallProgressIsMonotonicAndEndsAtOne) {
  for (const auto& [method, refine] : paths) {
    double last = 0;
    for (int s = 0; s < static_cast<int>(mesh_stage::done); ++s) {
      for (const double f : {0.0, 0.25, 0.5, 1.0}) {
        const double p = overall_progress(method, refine, static_cast<mesh_stage>(s), f);
        EXPECT_GE(p, last) << stage_name(static_cast<mesh_stage>(s)) << " " << f;
        EXPECT_LE(p, 1.0);
        last = p;
      }
    }
    EXPECT_NEAR(last, 1.0, 1e-12);
    EXPECT_EQ(overall_progress(method, refine, mesh_stage::done, 0.0), 1.0);
  }
  // Out-of-range fractions are clamped, NaN counts as nothing done.
  const double start = overall_progress(mesh_method::lattice, refine_mode::full, mesh_stage::refining, 0.0);
  EXPECT_EQ(overall_progress(mesh_method::lattice, refine_mode::full, mesh_stage::refining, -3.0), start);
  EXPECT_EQ(overall_progress(mesh_method::lattice, refine_mode::full, mesh_stage::refining, std::nan("")), start);
  EXPECT_EQ(overall_progress(mesh_method::lattice, refine_mode::full, mesh_stage::refining, 7.0),
            overall_progress(mesh_method::lattice, refine_mode::full, mesh_stage::certifying, 0.0));
}

TEST(StageWeights, ARealRunThroughTheProgressTokenNeverGoesBackwardsAndEndsAtOne) {
  auto mol = read_pqr_file(testing::molecule_path("fas2.pqr"));
  ASSERT_TRUE(mol.ok()) << mol.error().message();
  for (const auto& [method, refine] : paths) {
    mesh_params params;
    params.method = method;
    params.refine = refine;
    std::vector<double> seen;
    std::vector<mesh_stage> stages;
    progress_token token([&, method = method, refine = refine](mesh_stage stage, double fraction) {
      seen.push_back(overall_progress(method, refine, stage, fraction));
      stages.push_back(stage);
    });
    auto out = mesh_molecule(*mol, params, mesh_limits{}, token);
    ASSERT_TRUE(out.ok()) << out.error().message();
    ASSERT_GT(seen.size(), 3u);
    for (std::size_t i = 1; i < seen.size(); ++i) {
      EXPECT_GE(seen[i], seen[i - 1]) << method_name(method) << " " << refine_name(refine) << ": report " << i
                                      << " (" << stage_name(stages[i]) << ") after " << stage_name(stages[i - 1]);
    }
    EXPECT_EQ(seen.back(), 1.0);
    // Every stage the run reported has a share in its path's weights.
    for (const mesh_stage stage : stages) {
      if (stage == mesh_stage::done) continue;
      EXPECT_GT(share(method, refine, stage), 0.0) << stage_name(stage);
    }
  }
}

}  // namespace
}  // namespace tracemesh
