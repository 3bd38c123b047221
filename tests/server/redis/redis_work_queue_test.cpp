#include "server/redis/redis_work_queue.hpp"

#include <gtest/gtest.h>

#include <set>
#include <thread>

#include "redis_fixture.hpp"
#include "support/eventually.hpp"

namespace tracemesh::server::test {
namespace {

using namespace std::chrono_literals;

using RedisWorkQueue = SharedRedis;

TEST_F(RedisWorkQueue, EachJobGoesToExactlyOneReplica) {
  redis_work_queue a(*replica_a_, "replica-a");
  redis_work_queue b(*replica_b_, "replica-b");
  ASSERT_TRUE(a.ensure_group().ok());
  ASSERT_TRUE(b.ensure_group().ok());  // the group exists already: fine
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(a.push("job-" + std::to_string(i)).ok());

  const auto to_a = a.take(4, 0ms);
  const auto to_b = b.take(10, 0ms);
  ASSERT_TRUE(to_a.ok() && to_b.ok());
  EXPECT_EQ(to_a->size(), 4u);
  EXPECT_EQ(to_b->size(), 2u);
  std::set<std::string> delivered;
  for (const auto* batch : {&*to_a, &*to_b}) {
    for (const queue_entry& entry : *batch) delivered.insert(entry.job_id);
  }
  EXPECT_EQ(delivered.size(), 6u);  // no job twice, none lost
  EXPECT_EQ(*a.pending(), 6u);
  for (const queue_entry& entry : *to_a) ASSERT_TRUE(a.ack(entry.entry_id).ok());
  EXPECT_EQ(*a.pending(), 2u);
  EXPECT_TRUE(a.take(1, 0ms)->empty());  // nothing new
}

TEST_F(RedisWorkQueue, EntriesPushedBeforeTheGroupExistsAreDelivered) {
  redis_work_queue a(*replica_a_, "replica-a");
  ASSERT_TRUE(replica_a_->command({"XADD", a.stream_key(), "*", "job", "early"}).ok());
  ASSERT_TRUE(a.ensure_group().ok());
  const auto taken = a.take(1, 0ms);
  ASSERT_TRUE(taken.ok());
  ASSERT_EQ(taken->size(), 1u);
  EXPECT_EQ(taken->front().job_id, "early");
}

TEST_F(RedisWorkQueue, TakeWaitsForAJobPushedElsewhere) {
  redis_work_queue a(*replica_a_, "replica-a");
  redis_work_queue b(*replica_b_, "replica-b");
  ASSERT_TRUE(a.ensure_group().ok());
  std::thread pusher([&] {
    std::this_thread::sleep_for(50ms);
    EXPECT_TRUE(b.push("late").ok());
  });
  std::vector<queue_entry> taken;
  EXPECT_TRUE(tracemesh::testing::eventually([&] { return !(taken = a.take(1, 500ms).value()).empty(); }));
  pusher.join();
  ASSERT_EQ(taken.size(), 1u);
  EXPECT_EQ(taken.front().job_id, "late");
}

TEST_F(RedisWorkQueue, ADeadReplicasJobIsReclaimedAfterItsIdleTimeout) {
  redis_work_queue a(*replica_a_, "replica-a");
  redis_work_queue b(*replica_b_, "replica-b");
  ASSERT_TRUE(a.ensure_group().ok());
  ASSERT_TRUE(a.push("orphan").ok());
  ASSERT_EQ(a.take(1, 0ms)->size(), 1u);
  // Replica a "dies" holding it. Not idle long enough yet for a one-hour timeout:
  EXPECT_TRUE(b.reclaim(1h, 10)->empty());
  // Idle longer than a short timeout: b takes it over, once.
  std::this_thread::sleep_for(30ms);
  const auto reclaimed = b.reclaim(20ms, 10);
  ASSERT_TRUE(reclaimed.ok()) << reclaimed.error().message();
  ASSERT_EQ(reclaimed->size(), 1u);
  EXPECT_EQ(reclaimed->front().job_id, "orphan");
  ASSERT_TRUE(b.ack(reclaimed->front().entry_id).ok());
  EXPECT_EQ(*b.pending(), 0u);
  EXPECT_FALSE(*a.touch(reclaimed->front().entry_id));  // acknowledged: nothing to keep alive
}

TEST_F(RedisWorkQueue, TouchKeepsARunningJobFromBeingReclaimed) {
  redis_work_queue a(*replica_a_, "replica-a");
  redis_work_queue b(*replica_b_, "replica-b");
  ASSERT_TRUE(a.ensure_group().ok());
  ASSERT_TRUE(a.push("long-run").ok());
  const queue_entry entry = a.take(1, 0ms)->front();
  std::this_thread::sleep_for(30ms);
  // After the touch the entry's idle time counts from the touch: at most the time since, however long this test
  // pauses anywhere (an untouched entry would be idle for the 30 ms above and more).
  const auto touched_at = std::chrono::steady_clock::now();
  ASSERT_TRUE(*a.touch(entry.entry_id));
  const auto pending = replica_a_->command({"XPENDING", a.stream_key(), redis_work_queue::group, "-", "+", "10"});
  const auto since_touch = std::chrono::steady_clock::now() - touched_at;
  ASSERT_TRUE(pending.ok());
  ASSERT_EQ(pending->elements.size(), 1u);
  ASSERT_EQ(pending->elements[0].elements.size(), 4u);  // id, consumer, idle ms, deliveries
  EXPECT_LE(std::chrono::milliseconds(pending->elements[0].elements[2].integer),
            std::chrono::ceil<std::chrono::milliseconds>(since_touch));
  EXPECT_TRUE(b.reclaim(1h, 10)->empty());
}

TEST_F(RedisWorkQueue, RefusesABlockAsLongAsTheCommandTimeout) {
  redis_work_queue a(*replica_a_, "replica-a");
  ASSERT_TRUE(a.ensure_group().ok());
  const auto refused = a.take(1, limits().command_timeout);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code(), errc::invalid_argument);
  EXPECT_FALSE(a.take(0, 0ms).ok());
}

}  // namespace
}  // namespace tracemesh::server::test
