#include "server/redis/redis_run_lease.hpp"

#include <gtest/gtest.h>

#include <thread>

#include "redis_fixture.hpp"
#include "support/eventually.hpp"

namespace tracemesh::server::test {
namespace {

using namespace std::chrono_literals;

using RedisRunLease = SharedRedis;

TEST_F(RedisRunLease, TheSameJobRunsOnOneReplicaOnly) {
  redis_run_lease a(*replica_a_, "replica-a");
  redis_run_lease b(*replica_b_, "replica-b");
  EXPECT_TRUE(*a.acquire("job", 1h));
  EXPECT_FALSE(*b.acquire("job", 1h));
  EXPECT_EQ(b.holder("job")->value(), "replica-a");
  // b can neither extend nor drop a's lease.
  EXPECT_FALSE(*b.renew("job", 1h));
  EXPECT_FALSE(*b.release("job"));
  EXPECT_EQ(a.holder("job")->value(), "replica-a");

  EXPECT_TRUE(*a.release("job"));
  EXPECT_FALSE(a.holder("job")->has_value());
  EXPECT_TRUE(*b.acquire("job", 1h));
}

TEST_F(RedisRunLease, RenewExtendsAndAnExpiredLeaseCanBeTakenOver) {
  redis_run_lease a(*replica_a_, "replica-a");
  redis_run_lease b(*replica_b_, "replica-b");
  // A ttl no pause of the test outlasts, then a renewal past it.
  ASSERT_TRUE(*a.acquire("job", 1min));
  ASSERT_TRUE(*a.renew("job", 1h));
  EXPECT_GT(replica_a_->command({"PTTL", a.lease_key("job")})->integer, 60'000);

  ASSERT_TRUE(*a.renew("job", 20ms));
  // A replica that stops renewing (died) loses the lease once the ttl passes.
  ASSERT_TRUE(tracemesh::testing::eventually([&] { return !a.holder("job")->has_value(); }));
  EXPECT_TRUE(*b.acquire("job", 1h));
  EXPECT_FALSE(*a.renew("job", 1h));  // too late: it is b's now
  EXPECT_FALSE(*a.release("job"));
  EXPECT_EQ(a.holder("job")->value(), "replica-b");
}

TEST_F(RedisRunLease, RefusesANonPositiveTtl) {
  redis_run_lease a(*replica_a_, "replica-a");
  EXPECT_EQ(a.acquire("job", 0ms).error().code(), errc::invalid_argument);
  EXPECT_EQ(a.renew("job", -1ms).error().code(), errc::invalid_argument);
}

}  // namespace
}  // namespace tracemesh::server::test
