#include "server/redis/redis_job_coordinator.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "server/observability/logging.hpp"
#include "support/eventually.hpp"
#include "support/redis_process.hpp"

namespace tracemesh::server::test {
namespace {

using namespace std::chrono_literals;
using tracemesh::testing::eventually;

/// One replica's coordinator on a real redis-server, its job queue running a fake work that reports progress and
/// waits until released (or cancelled), so the tests see every state.
class RedisJobCoordinator : public ::testing::Test {
 protected:
  void SetUp() override {
    TRACEMESH_REQUIRE_REDIS_SERVER();
    ASSERT_TRUE(redis_.start());
    char pattern[] = "/tmp/tracemesh-coordinator-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    config_.cache_dir = pattern;
    config_.store_url = redis_.url();
    config_.replica_name = "A";
    config_.limits.redis.connect_timeout = 300ms;
    config_.limits.redis.command_timeout = 1s;
    config_.limits.redis.reconnect_backoff_max = 200ms;
    config_.limits.replicas.reclaim_timeout = 1s;
    config_.limits.replicas.heartbeat = 50ms;
    config_.limits.replicas.take_block = 200ms;
    config_.limits.max_queue = 2;
    cache_ = std::make_unique<result_cache>(config_.cache_dir, cache_limits{});
    ASSERT_TRUE(cache_->open().ok());
    replica_ = std::make_unique<redis_replica>(redis_.endpoint(), config_, *cache_, stats_);
    jobs_ = std::make_unique<job_queue>(
        job_queue_options{1, 8, 64, std::chrono::minutes(1)},
        [this](const std::string&, const job_input&, progress_token& token) -> result<job_output> {
          token.report(mesh_stage::sampling, 0.5);
          while (!released_ && !token.cancelled()) std::this_thread::sleep_for(5ms);
          if (token.cancelled()) return status(errc::cancelled, "cancelled");
          return job_output{std::make_shared<const surface_mesh>(), std::make_shared<const std::string>("{}"), false};
        },
        stats_);
    coordinator_ = std::make_unique<redis_job_coordinator>(*replica_, *jobs_, 1, stats_, *log_);
    ASSERT_TRUE(coordinator_->start().ok());
  }
  void TearDown() override {
    released_ = true;
    // As the service: the queue ends (its listeners call the coordinator) before the coordinator goes.
    if (jobs_) jobs_->shutdown(std::chrono::seconds(5));
    coordinator_.reset();
    jobs_.reset();
    std::error_code ignored;
    if (!config_.cache_dir.empty()) std::filesystem::remove_all(config_.cache_dir, ignored);
  }

  static std::shared_ptr<const job_input> input() {
    auto in = std::make_shared<job_input>();
    in->mol.atoms.push_back(atom{{0, 0, 0}, 1.5, 0.0});
    return in;
  }
  std::optional<job_snapshot> state_of(const std::string& id) {
    const auto found = coordinator_->find(id);
    return found.ok() ? *found : std::nullopt;
  }

  const std::string id_ = std::string(64, 'c');
  testing::redis_process redis_;
  server_config config_;
  std::shared_ptr<spdlog::logger> log_ = make_null_logger();
  metrics stats_;
  std::unique_ptr<result_cache> cache_;
  std::unique_ptr<redis_replica> replica_;
  std::unique_ptr<job_queue> jobs_;
  std::unique_ptr<redis_job_coordinator> coordinator_;
  std::atomic<bool> released_{false};
};

TEST_F(RedisJobCoordinator, AnAcceptedJobIsTakenRunAndRecordedDone) {
  const accept_result accepted = coordinator_->accept(id_, input(), std::string(64, 'a'));
  ASSERT_TRUE(accepted.error.ok()) << accepted.error.message();
  EXPECT_EQ(accepted.outcome, submit_outcome::accepted);
  EXPECT_EQ(coordinator_->accept(id_, input(), std::string(64, 'b')).outcome, submit_outcome::coalesced);
  ASSERT_TRUE(eventually([&] {
    const auto job = state_of(id_);
    return job && job->state == job_state::running && job->progress > 0;
  })) << "the consumer took the job and its progress is recorded";
  released_ = true;
  ASSERT_TRUE(eventually([&] {
    const auto job = state_of(id_);
    return job && job->state == job_state::done;
  }));
  EXPECT_TRUE(eventually([&] { return *replica_->queue.pending() == 0; })) << "the entry is acknowledged";
  EXPECT_EQ(replica_->client.command({"XLEN", replica_->queue.stream_key()})->integer, 0);
}

TEST_F(RedisJobCoordinator, TheLastOwnersWithdrawalCancelsTheRunningJob) {
  ASSERT_TRUE(coordinator_->accept(id_, input(), std::string(64, 'a')).error.ok());
  ASSERT_TRUE(eventually([&] {
    const auto job = state_of(id_);
    return job && job->state == job_state::running;
  }));
  EXPECT_EQ(coordinator_->withdraw(id_, std::string(64, 'z')).outcome, cancel_outcome::not_owner);
  EXPECT_EQ(coordinator_->withdraw(id_, std::string(64, 'a')).outcome, cancel_outcome::cancelled);
  ASSERT_TRUE(eventually([&] {
    const auto job = state_of(id_);
    return job && job->state == job_state::cancelled;
  }));
  EXPECT_EQ(coordinator_->withdraw(id_, std::string(64, 'a')).outcome, cancel_outcome::already_final);
}

TEST_F(RedisJobCoordinator, WithoutRedisItIsUnreadyRefusesJobsAndRecoversWhenRedisIsBack) {
  EXPECT_FALSE(coordinator_->unready_reason().has_value());
  redis_.stop();
  ASSERT_TRUE(eventually([&] { return coordinator_->unready_reason().has_value(); }));
  EXPECT_NE(coordinator_->unready_reason()->find("unreachable"), std::string::npos);
  const accept_result refused = coordinator_->accept(id_, input(), std::string(64, 'a'));
  EXPECT_FALSE(refused.error.ok()) << "nothing is accepted that cannot be recorded";
  EXPECT_FALSE(coordinator_->find(id_).ok());
  ASSERT_TRUE(redis_.restart());  // empty: no append-only file in this test
  ASSERT_TRUE(eventually([&] { return !coordinator_->unready_reason().has_value(); }));
  ASSERT_TRUE(eventually([&] { return coordinator_->accept(id_, input(), std::string(64, 'a')).error.ok(); }))
      << "the stream's group is made again on a Redis that came back empty";
  released_ = true;
  EXPECT_TRUE(eventually([&] {
    const auto job = state_of(id_);
    return job && job->state == job_state::done;
  }));
}

}  // namespace
}  // namespace tracemesh::server::test
