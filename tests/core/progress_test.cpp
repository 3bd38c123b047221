#include "core/progress.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <utility>
#include <vector>

namespace tracemesh {
namespace {

struct recorded {
  std::vector<std::pair<mesh_stage, double>> reports;
  progress_token token{[this](mesh_stage stage, double fraction) { reports.emplace_back(stage, fraction); }};
};

TEST(ProgressToken, ALowerFractionOfTheSameStageIsDropped) {
  recorded r;
  EXPECT_TRUE(r.token.report(mesh_stage::tracing, 0.5));
  EXPECT_TRUE(r.token.report(mesh_stage::tracing, 0.4));  // still asks the work to go on
  EXPECT_TRUE(r.token.report(mesh_stage::tracing, 0.5));  // equal is passed on
  EXPECT_TRUE(r.token.report(mesh_stage::tracing, 0.7));
  const std::vector<std::pair<mesh_stage, double>> expected{
      {mesh_stage::tracing, 0.5}, {mesh_stage::tracing, 0.5}, {mesh_stage::tracing, 0.7}};
  EXPECT_EQ(r.reports, expected);
}

TEST(ProgressToken, AnotherStageStartsAgainFromItsOwnFraction) {
  recorded r;
  r.token.report(mesh_stage::roots, 0.9);
  r.token.report(mesh_stage::tracing, 0.0);
  r.token.report(mesh_stage::tracing, 0.1);
  ASSERT_EQ(r.reports.size(), 3U);
  EXPECT_EQ(r.reports[1], std::make_pair(mesh_stage::tracing, 0.0));
}

TEST(ProgressToken, WorkersReportingConcurrentlyNeverMakeItGoBackwards) {
  // As the meshers do: each worker numbers its finished item, then reports; the listener sees them in lock order.
  recorded r;
  std::atomic<int> done{0};
  constexpr int per_thread = 2000, threads = 4;
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      for (int i = 0; i < per_thread; ++i) {
        const double fraction = static_cast<double>(++done) / (per_thread * threads);
        r.token.report(mesh_stage::refining, fraction);
      }
    });
  }
  for (std::thread& w : workers) w.join();
  ASSERT_FALSE(r.reports.empty());
  for (std::size_t i = 1; i < r.reports.size(); ++i) EXPECT_GE(r.reports[i].second, r.reports[i - 1].second) << i;
  EXPECT_EQ(r.reports.back().second, 1.0);
}

TEST(ProgressToken, CancelledWorkIsToldToStop) {
  recorded r;
  r.token.cancel();
  EXPECT_FALSE(r.token.report(mesh_stage::tracing, 0.1));
  EXPECT_TRUE(r.token.cancelled());
}

}  // namespace
}  // namespace tracemesh
