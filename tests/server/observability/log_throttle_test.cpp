// Tests of server/observability/log_throttle.hpp: one line per client per interval, a bounded table, and the count
// of lines held back. Time is passed in, never waited for.
#include "server/observability/log_throttle.hpp"

#include <gtest/gtest.h>

#include <string>

namespace tracemesh::server {
namespace {

using namespace std::chrono_literals;
using clock_type = log_throttle::clock;

TEST(LogThrottleTest, OneLinePerClientPerInterval) {
  log_throttle throttle(60s, 16);
  const clock_type::time_point start{};
  std::uint64_t suppressed = 99;
  EXPECT_TRUE(throttle.admit("ip:192.0.2.1", start, suppressed));
  EXPECT_EQ(suppressed, 0u);
  for (int i = 1; i <= 1000; ++i) EXPECT_FALSE(throttle.admit("ip:192.0.2.1", start + 59s, suppressed));
  EXPECT_TRUE(throttle.admit("ip:192.0.2.2", start + 59s, suppressed)) << "another client has its own line";
  EXPECT_EQ(suppressed, 1000u) << "it says how many were held back";
  EXPECT_TRUE(throttle.admit("ip:192.0.2.1", start + 60s, suppressed)) << "the next interval";
  EXPECT_EQ(suppressed, 0u);
}

TEST(LogThrottleTest, ManyClientsNeitherGrowTheTableNorFloodTheLog) {
  log_throttle throttle(60s, 4);
  const clock_type::time_point start{};
  std::uint64_t suppressed = 0;
  int logged = 0;
  for (int i = 0; i < 10000; ++i) logged += throttle.admit("ip:10.0." + std::to_string(i) , start + 1s, suppressed);
  EXPECT_EQ(logged, 4) << "at most max_clients lines per interval";
  EXPECT_TRUE(throttle.admit("ip:fresh", start + 61s, suppressed)) << "expired clients are forgotten";
  EXPECT_EQ(suppressed, 9996u);
}

}  // namespace
}  // namespace tracemesh::server
