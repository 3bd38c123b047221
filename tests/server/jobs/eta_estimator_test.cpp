#include "server/jobs/eta_estimator.hpp"

#include <gtest/gtest.h>

#include <chrono>

namespace tracemesh::server {
namespace {

using namespace std::chrono_literals;
using clock = eta_estimator::clock;

TEST(EtaEstimator, UnknownBeforeTheRunStartsAndEarlyInIt) {
  eta_estimator eta;
  const auto t0 = clock::time_point{} + 1h;
  EXPECT_FALSE(eta.remaining_seconds(t0));
  eta.observe(0.5, t0);  // not started: ignored
  EXPECT_FALSE(eta.remaining_seconds(t0));
  eta.start(t0);
  eta.observe(eta_estimator::min_progress / 2, t0 + 1s);
  EXPECT_FALSE(eta.remaining_seconds(t0 + 1s));
}

TEST(EtaEstimator, AtASteadyRateItIsTheTimeLeftAndCountsDownBetweenReports) {
  eta_estimator eta;
  const auto t0 = clock::time_point{} + 1h;
  eta.start(t0);
  for (int s = 1; s <= 5; ++s) eta.observe(s * 0.1, t0 + s * 1s);  // 10 s in all
  ASSERT_TRUE(eta.remaining_seconds(t0 + 5s));
  EXPECT_NEAR(*eta.remaining_seconds(t0 + 5s), 5.0, 1e-9);
  EXPECT_NEAR(*eta.remaining_seconds(t0 + 7s), 3.0, 1e-9);
  EXPECT_EQ(*eta.remaining_seconds(t0 + 60s), 0.0) << "never negative";
}

TEST(EtaEstimator, AJumpInProgressMovesTheEtaOnlyPartWay) {
  eta_estimator eta;
  const auto t0 = clock::time_point{} + 1h;
  eta.start(t0);
  for (int s = 1; s <= 4; ++s) eta.observe(s * 0.05, t0 + s * 1s);  // 20 s in all: 16 s left at 4 s
  const double before = *eta.remaining_seconds(t0 + 4s);
  EXPECT_NEAR(before, 16.0, 1e-9);
  eta.observe(0.8, t0 + 5s);  // a stage much faster than its weight: the raw estimate says 1.25 s left
  const double after = *eta.remaining_seconds(t0 + 5s);
  EXPECT_LT(after, before);
  EXPECT_GT(after, 10.0) << "smoothed: one report moves the estimate by the smoothing weight only";
}

TEST(EtaEstimator, ABurstOfReportsCountsAsOne) {
  eta_estimator eta;
  const auto t0 = clock::time_point{} + 1h;
  eta.start(t0);
  eta.observe(0.1, t0 + 1s);  // 10 s in all
  for (int i = 0; i < 100; ++i) eta.observe(0.9, t0 + 1s + std::chrono::milliseconds(i));
  EXPECT_NEAR(*eta.remaining_seconds(t0 + 1s), 9.0, 1e-9) << "within min_interval the first estimate stands";
}

}  // namespace
}  // namespace tracemesh::server
