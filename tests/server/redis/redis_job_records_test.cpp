#include "server/redis/redis_job_records.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "redis_fixture.hpp"

namespace tracemesh::server::test {
namespace {

using namespace std::chrono_literals;

const std::string records_job_id(64, '1');

using RedisJobRecords = SharedRedis;

TEST_F(RedisJobRecords, ARecordWrittenByOneReplicaIsReadByAnother) {
  redis_job_records a(*replica_a_, 24h);
  redis_job_records b(*replica_b_, 24h);
  const stored_job written = queued_job(records_job_id);
  ASSERT_TRUE(a.put(written).ok());

  const auto read = b.find(records_job_id);
  ASSERT_TRUE(read.ok()) << read.error().message();
  ASSERT_TRUE(read->has_value());
  const stored_job& record = **read;
  EXPECT_EQ(record.id, records_job_id);
  EXPECT_EQ(record.state, job_state::queued);
  EXPECT_EQ(record.parameters, written.parameters);
  EXPECT_EQ(record.format, proto::mesh_format::glb);
  EXPECT_EQ(record.owners, written.owners);
  EXPECT_EQ(record.accepted_ms, written.accepted_ms);
  EXPECT_EQ(record.finished_ms, 0);
  EXPECT_EQ(record.report, nullptr);
  // Unfinished: no expiry.
  EXPECT_EQ(replica_a_->command({"PTTL", a.record_key(records_job_id)})->integer, -1);

  const auto unknown = b.find(std::string(64, '2'));
  ASSERT_TRUE(unknown.ok());
  EXPECT_FALSE(unknown->has_value());
}

TEST_F(RedisJobRecords, AFinishedRecordExpiresAfterTheRetention) {
  redis_job_records a(*replica_a_, 1h);
  stored_job record = queued_job(records_job_id);
  ASSERT_TRUE(a.put(record).ok());
  record.state = job_state::done;
  record.report = std::make_shared<const std::string>(R"({"triangles":4})");
  record.finished_ms = unix_millis();
  ASSERT_TRUE(a.put(record).ok());

  for (const std::string& key : {a.record_key(records_job_id), a.owners_key(records_job_id)}) {
    const long long ttl_ms = replica_a_->command({"PTTL", key})->integer;
    EXPECT_GT(ttl_ms, 0) << key;
    EXPECT_LE(ttl_ms, 3'600'000) << key;
  }
  const auto read = redis_job_records(*replica_b_, 1h).find(records_job_id);
  ASSERT_TRUE(read.ok() && read->has_value());
  EXPECT_EQ((*read)->state, job_state::done);
  ASSERT_NE((*read)->report, nullptr);
  EXPECT_EQ(*(*read)->report, R"({"triangles":4})");

  // A record that ended longer ago than the retention is gone at once.
  record.finished_ms = unix_millis() - 2 * 3'600'000;
  ASSERT_TRUE(a.put(record).ok());
  EXPECT_FALSE(a.find(records_job_id)->has_value());
}

TEST_F(RedisJobRecords, OwnersAreSharedAndNeverRecreateAnExpiredJob) {
  redis_job_records a(*replica_a_, 24h);
  redis_job_records b(*replica_b_, 24h);
  ASSERT_TRUE(a.put(queued_job(records_job_id)).ok());
  const std::string second(64, 'b');
  ASSERT_TRUE(b.add_owner(records_job_id, second).ok());
  EXPECT_EQ(a.find(records_job_id)->value().owners.size(), 2u);
  EXPECT_TRUE(*a.remove_owner(records_job_id, std::string(64, 'a')));
  EXPECT_FALSE(*a.remove_owner(records_job_id, std::string(64, 'a')));
  EXPECT_EQ(b.find(records_job_id)->value().owners, std::vector<std::string>{second});

  const std::string unknown(64, '3');
  const status refused = b.add_owner(unknown, second);
  EXPECT_EQ(refused.code(), errc::invalid_argument);
  EXPECT_EQ(replica_a_->command({"EXISTS", a.owners_key(unknown)})->integer, 0);
}

TEST_F(RedisJobRecords, ProgressOfARunningJobIsSeenEverywhere) {
  redis_job_records a(*replica_a_, 24h);
  redis_job_records b(*replica_b_, 24h);
  ASSERT_TRUE(a.put(queued_job(records_job_id)).ok());
  ASSERT_TRUE(*a.set_progress(records_job_id, "sampling", 0.25, 12.5));
  const auto live = b.find_progress(records_job_id);
  ASSERT_TRUE(live.ok() && live->has_value());
  EXPECT_EQ((*live)->stage, "sampling");
  EXPECT_DOUBLE_EQ(std::stod((*live)->progress), 0.25);
  EXPECT_DOUBLE_EQ(std::stod((*live)->eta_s), 12.5);
  ASSERT_TRUE(*a.set_progress(records_job_id, "tracing", 0.5, std::nullopt));
  EXPECT_EQ(b.find_progress(records_job_id)->value().eta_s, "");  // unknown
  // The progress fields do not disturb the record.
  EXPECT_EQ(b.find(records_job_id)->value().state, job_state::queued);

  // A late report for an unknown (purged) job writes nothing.
  const std::string gone(64, '4');
  EXPECT_FALSE(*a.set_progress(gone, "sampling", 0.9, 1.0));
  EXPECT_FALSE(b.find_progress(gone)->has_value());
  EXPECT_EQ(replica_a_->command({"EXISTS", a.record_key(gone)})->integer, 0);
}

TEST_F(RedisJobRecords, AForeignHashIsAnErrorNotARecord) {
  redis_job_records a(*replica_a_, 24h);
  ASSERT_TRUE(replica_a_->command({"HSET", a.record_key(records_job_id), "state", "done"}).ok());
  const auto read = a.find(records_job_id);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code(), errc::io_error);
  EXPECT_NE(read.error().message().find("malformed job record"), std::string::npos) << read.error().message();

  ASSERT_TRUE(replica_a_->command({"HSET", a.record_key(records_job_id), "parameters", "", "format", "off",
                                   "error_code", "", "error_message", "", "accepted_ms", "1", "finished_ms", "x"})
                  .ok());
  EXPECT_FALSE(a.find(records_job_id).ok());  // finished_ms not a number
}

TEST_F(RedisJobRecords, WritesFailAsValuesWhenRedisIsDown) {
  redis_job_records a(*replica_a_, 24h);
  redis_.stop();
  const status failed = a.put(queued_job(records_job_id));
  EXPECT_EQ(failed.code(), errc::io_error);
  EXPECT_NE(failed.message().find("unreachable"), std::string::npos) << failed.message();
  EXPECT_FALSE(a.find(records_job_id).ok());
}


// ---- what the replicas' coordinator does with the records (redis_job_coordinator.hpp) ----

constexpr const char* stream = "tracemesh:queue";

/// A stream with its consumer group, as redis_work_queue::ensure_group makes it.
void make_group(redis_client& client) {
  ASSERT_TRUE(client.command({"XGROUP", "CREATE", stream, "workers", "0", "MKSTREAM"}).ok());
}

stored_job submission(const std::string& id, char owner) {
  stored_job record = queued_job(id);
  record.owners = {std::string(64, owner)};
  return record;
}

TEST_F(RedisJobRecords, AcceptQueuesANewJobOnceAndCoalescesTheSameJobFromAnotherReplica) {
  make_group(*replica_a_);
  redis_job_records a(*replica_a_, 24h);
  redis_job_records b(*replica_b_, 24h);
  const auto first = a.accept_and_queue(submission(records_job_id, 'a'), "input bytes", stream, "workers", 8);
  ASSERT_TRUE(first.ok()) << first.error().message();
  EXPECT_EQ(*first, redis_job_records::accept_outcome::accepted);
  const auto second = b.accept_and_queue(submission(records_job_id, 'b'), "input bytes", stream, "workers", 8);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(*second, redis_job_records::accept_outcome::coalesced);

  EXPECT_EQ(replica_a_->command({"XLEN", stream})->integer, 1) << "one stream entry for the job";
  const auto record = b.find(records_job_id);
  ASSERT_TRUE(record.ok() && record->has_value());
  EXPECT_EQ((*record)->owners.size(), 2u);
  EXPECT_EQ(*b.input(records_job_id), std::optional<std::string>("input bytes"));
}

TEST_F(RedisJobRecords, AcceptRefusesPastTheWaitingLimitButStillCoalesces) {
  make_group(*replica_a_);
  redis_job_records a(*replica_a_, 24h);
  ASSERT_EQ(*a.accept_and_queue(submission(records_job_id, 'a'), "x", stream, "workers", 1),
            redis_job_records::accept_outcome::accepted);
  EXPECT_EQ(*a.accept_and_queue(submission(std::string(64, '2'), 'a'), "x", stream, "workers", 1),
            redis_job_records::accept_outcome::queue_full);
  EXPECT_EQ(*a.accept_and_queue(submission(records_job_id, 'c'), "x", stream, "workers", 1),
            redis_job_records::accept_outcome::coalesced);
  // Delivered (pending) entries do not wait: there is room again.
  ASSERT_TRUE(replica_a_->command({"XREADGROUP", "GROUP", "workers", "w", "COUNT", "1", "STREAMS", stream, ">"}).ok());
  EXPECT_EQ(*a.accept_and_queue(submission(std::string(64, '2'), 'a'), "x", stream, "workers", 1),
            redis_job_records::accept_outcome::accepted);
}

TEST_F(RedisJobRecords, WithdrawCancelsAQueuedJobAndFlagsARunningOne) {
  make_group(*replica_a_);
  redis_job_records a(*replica_a_, 24h);
  redis_job_records b(*replica_b_, 24h);
  using outcome = redis_job_records::withdraw_outcome;
  EXPECT_EQ(*b.withdraw(records_job_id, std::string(64, 'a')), outcome::not_found);
  ASSERT_TRUE(a.accept_and_queue(submission(records_job_id, 'a'), "x", stream, "workers", 8).ok());
  ASSERT_TRUE(a.accept_and_queue(submission(records_job_id, 'b'), "x", stream, "workers", 8).ok());
  EXPECT_EQ(*b.withdraw(records_job_id, std::string(64, 'z')), outcome::not_owner);
  EXPECT_EQ(*b.withdraw(records_job_id, std::string(64, 'b')), outcome::withdrawn);
  ASSERT_TRUE(*a.mark_running(records_job_id, "A"));
  EXPECT_FALSE(*a.cancel_requested(records_job_id));
  EXPECT_EQ(*b.withdraw(records_job_id, std::string(64, 'a')), outcome::cancelling);
  EXPECT_TRUE(*a.cancel_requested(records_job_id)) << "the running replica sees the request at its next heartbeat";

  const std::string queued_id(64, '3');
  ASSERT_TRUE(a.accept_and_queue(submission(queued_id, 'a'), "x", stream, "workers", 8).ok());
  EXPECT_EQ(*b.withdraw(queued_id, std::string(64, 'a')), outcome::cancelled);
  const auto cancelled = a.find(queued_id);
  ASSERT_TRUE(cancelled.ok() && cancelled->has_value());
  EXPECT_EQ((*cancelled)->state, job_state::cancelled);
  EXPECT_GT(replica_a_->command({"PTTL", a.record_key(queued_id)})->integer, 0) << "a final record expires";
  EXPECT_FALSE(a.input(queued_id)->has_value()) << "its input is dropped";
  EXPECT_EQ(*b.withdraw(queued_id, std::string(64, 'a')), outcome::already_final);
  EXPECT_FALSE(*a.mark_running(queued_id, "A")) << "a cancelled job is not started";
}

TEST_F(RedisJobRecords, FinishKeepsTheOwnersAndEncodingsMergeIntoTheReport) {
  make_group(*replica_a_);
  redis_job_records a(*replica_a_, 24h);
  redis_job_records b(*replica_b_, 24h);
  ASSERT_TRUE(a.accept_and_queue(submission(records_job_id, 'a'), "x", stream, "workers", 8).ok());
  EXPECT_EQ(b.set_encoding(records_job_id, "off", R"({"bytes":10})").code(), errc::invalid_argument) << "not done yet";
  stored_job done = **a.find(records_job_id);
  done.state = job_state::done;
  done.report = std::make_shared<const std::string>(R"({"triangles":4,"encodings":{}})");
  done.finished_ms = unix_millis();
  ASSERT_TRUE(a.finish(done).ok());
  ASSERT_TRUE(a.set_encoding(records_job_id, "off", R"({"bytes":10})").ok());
  ASSERT_TRUE(b.set_encoding(records_job_id, "draco", R"({"bytes":3})").ok());

  const stored_job read = **b.find(records_job_id);
  EXPECT_EQ(read.state, job_state::done);
  EXPECT_EQ(read.owners, std::vector<std::string>{std::string(64, 'a')});
  const nlohmann::json report = nlohmann::json::parse(*read.report);
  EXPECT_EQ(report["triangles"], 4);
  EXPECT_EQ(report["encodings"]["off"]["bytes"], 10);
  EXPECT_EQ(report["encodings"]["draco"]["bytes"], 3);
  EXPECT_FALSE(a.input(records_job_id)->has_value());
}

}  // namespace
}  // namespace tracemesh::server::test
