#include "server/redis/redis_job_events.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <iostream>
#include <thread>

#include "redis_fixture.hpp"
#include "support/eventually.hpp"
#include "server/redis/redis_job_records.hpp"

namespace tracemesh::server::test {
namespace {

using namespace std::chrono_literals;

using tracemesh::testing::eventually;

const std::string events_job_id(64, '1');
const std::string other_job(64, '2');

using RedisJobEvents = SharedRedis;

TEST_F(RedisJobEvents, ARecordWrittenOnOneReplicaMovesTheVersionSeenOnAnother) {
  redis_job_records writer(*replica_a_, 24h);
  redis_job_events events(redis_.endpoint(), limits(), writer.events_channel(), 16, 20ms);
  EXPECT_FALSE(events.version(events_job_id)) << "no signal before the subscription: callers read the record";
  events.start();
  ASSERT_TRUE(eventually([&] { return events.subscribed(); }));
  const std::uint64_t before = *events.version(events_job_id);

  ASSERT_TRUE(writer.put(queued_job(events_job_id)).ok());
  ASSERT_TRUE(writer.mark_running(events_job_id, "replica-a").ok());  // published "running <id>"
  ASSERT_TRUE(eventually([&] { return events.version(events_job_id) != before; }));
  const std::uint64_t running = *events.version(events_job_id);
  EXPECT_EQ(events.remembered(), 1u);

  // A progress write publishes when the progress changed, and only then.
  const auto written_at = std::chrono::steady_clock::now();
  ASSERT_TRUE(writer.set_progress(events_job_id, "surface", 0.5, 3.0).ok());
  ASSERT_TRUE(eventually([&] { return events.version(events_job_id) != running; }));
  std::cout << "[ latency  ] progress write to subscriber: "
            << std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - written_at).count()
            << " ms\n";
  const std::uint64_t half = *events.version(events_job_id);
  const std::uint64_t messages = events.stats().messages;
  ASSERT_TRUE(writer.set_progress(events_job_id, "surface", 0.5, 2.0).ok());  // the ETA alone
  ASSERT_TRUE(writer.set_progress(events_job_id, "surface", 0.75, 1.0).ok());
  ASSERT_TRUE(eventually([&] { return events.version(events_job_id) != half; }));
  EXPECT_EQ(events.stats().messages, messages + 1);

  // Another job's message leaves this one's version alone.
  const std::uint64_t three_quarters = *events.version(events_job_id);
  ASSERT_TRUE(writer.put(queued_job(other_job)).ok());
  ASSERT_TRUE(writer.mark_running(other_job, "replica-a").ok());
  ASSERT_TRUE(eventually([&] { return events.remembered() == 2u; }));
  EXPECT_EQ(*events.version(events_job_id), three_quarters);

  // The final record: the version moves on and the finished job is forgotten.
  stored_job done = queued_job(events_job_id);
  done.state = job_state::done;
  done.finished_ms = unix_millis();
  ASSERT_TRUE(writer.finish(done).ok());
  ASSERT_TRUE(eventually([&] { return events.remembered() == 1u; }));
  EXPECT_NE(*events.version(events_job_id), three_quarters);
}

TEST_F(RedisJobEvents, TheMapIsBoundedAndAForgottenJobStillSeesAChange) {
  redis_job_records writer(*replica_a_, 24h);
  redis_job_events events(redis_.endpoint(), limits(), writer.events_channel(), 2, 20ms);
  events.start();
  ASSERT_TRUE(eventually([&] { return events.subscribed(); }));
  const std::uint64_t first = *events.version(events_job_id);
  const std::string running = redis_job_events::message("running", events_job_id);
  ASSERT_TRUE(replica_a_->command({"PUBLISH", writer.events_channel(), running}).ok());
  ASSERT_TRUE(eventually([&] { return events.version(events_job_id) != first; }));
  const std::uint64_t seen = *events.version(events_job_id);
  for (char c : std::string("abc")) {
    ASSERT_TRUE(replica_a_
                    ->command({"PUBLISH", writer.events_channel(),
                               redis_job_events::message("running", std::string(64, c))})
                    .ok());
  }
  ASSERT_TRUE(eventually([&] { return events.stats().messages == 4u; }));
  EXPECT_EQ(events.remembered(), 2u);
  EXPECT_NE(*events.version(events_job_id), seen) << "forgotten: its streams read the record once more";
}

TEST_F(RedisJobEvents, TheSubscriberSurvivesARedisRestart) {
  redis_job_records writer(*replica_a_, 24h);
  redis_job_events events(redis_.endpoint(), limits(), writer.events_channel(), 16, 20ms);
  events.start();
  ASSERT_TRUE(eventually([&] { return events.subscribed(); }));
  const std::uint64_t before = *events.version(events_job_id);

  redis_.stop();
  ASSERT_TRUE(eventually([&] { return !events.subscribed(); }));
  EXPECT_FALSE(events.version(events_job_id)) << "while unsubscribed, callers read the record (and find Redis away)";
  ASSERT_TRUE(redis_.restart());
  ASSERT_TRUE(eventually([&] { return events.subscribed(); }));
  EXPECT_EQ(events.stats().subscribes, 2u);
  // Messages may have been lost meanwhile: resubscribing moves every job's version.
  const std::uint64_t resubscribed = *events.version(events_job_id);
  EXPECT_NE(resubscribed, before);

  // And a change published after the restart arrives.
  redis_client writer_client(redis_.endpoint(), limits());
  redis_job_records after(writer_client, 24h);
  ASSERT_TRUE(after.put(queued_job(events_job_id)).ok());
  ASSERT_TRUE(after.mark_running(events_job_id, "replica-a").ok());
  ASSERT_TRUE(eventually([&] { return events.version(events_job_id) != resubscribed; }));
  EXPECT_GE(events.stats().failures, 1u);
}

}  // namespace
}  // namespace tracemesh::server::test
