#include "server/redis/redis_job_store.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <future>
#include <thread>

#include "redis_fixture.hpp"
#include "server/storage/job_store.hpp"

namespace tracemesh::server::test {
namespace {

using namespace std::chrono_literals;

const std::string stored_job_id(64, '7');

surface_mesh tetrahedron() {
  surface_mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.normals = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.atom_index = {0, 0, 0, 0};
  mesh.triangles = {{{0, 2, 1}}, {{0, 1, 3}}, {{0, 3, 2}}, {{1, 2, 3}}};
  return mesh;
}

stored_job sync_job() {
  stored_job record;
  record.id = stored_job_id;
  record.parameters = "density=1";
  record.accepted_ms = unix_millis();
  return record;
}

/// Two replicas' job record stores on one Redis and one result directory (as two tracemeshd --store processes).
class RedisJobStore : public SharedRedis {
 protected:
  void SetUp() override {
    SharedRedis::SetUp();
    if (IsSkipped()) return;
    char pattern[] = "/tmp/tracemesh-shared-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    for (auto* cache : {&cache_a_, &cache_b_}) {
      *cache = std::make_unique<result_cache>(dir_, cache_limits{1u << 20, 1u << 24});
      ASSERT_TRUE((*cache)->open().ok());
    }
    limits_.reclaim_timeout = 300ms;
    limits_.follow_poll = 10ms;
    records_a_ = std::make_unique<redis_job_records>(*replica_a_, 24h);
    records_b_ = std::make_unique<redis_job_records>(*replica_b_, 24h);
    lease_a_ = std::make_unique<redis_run_lease>(*replica_a_, "A");
    lease_b_ = std::make_unique<redis_run_lease>(*replica_b_, "B");
    a_ = std::make_unique<redis_job_store>(*records_a_, *lease_a_, *cache_a_, stats_a_, limits_);
    b_ = std::make_unique<redis_job_store>(*records_b_, *lease_b_, *cache_b_, stats_b_, limits_);
  }
  void TearDown() override {
    std::error_code ignored;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ignored);
  }

  std::filesystem::path dir_;
  replica_limits limits_;
  metrics stats_a_, stats_b_;
  std::unique_ptr<result_cache> cache_a_, cache_b_;
  std::unique_ptr<redis_job_records> records_a_, records_b_;
  std::unique_ptr<redis_run_lease> lease_a_, lease_b_;
  std::unique_ptr<redis_job_store> a_, b_;
};

TEST_F(RedisJobStore, AMeshCompletedByOneReplicaIsFoundByAnother) {
  EXPECT_EQ(b_->mesh(stored_job_id), nullptr);
  const auto report = std::make_shared<const std::string>(R"({"triangles":4})");
  ASSERT_TRUE(a_->complete(stored_job_id, sync_job(), tetrahedron(), report).ok());

  const std::optional<stored_job> record = b_->find(stored_job_id);
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->state, job_state::done);
  const auto mesh = b_->mesh(stored_job_id);
  ASSERT_NE(mesh, nullptr);
  EXPECT_EQ(mesh->positions, tetrahedron().positions);
  EXPECT_EQ(mesh->triangles, tetrahedron().triangles);
  ASSERT_TRUE(b_->record_encoding(stored_job_id, "off", {{"bytes", 42}}).ok());
  EXPECT_NE(a_->find(stored_job_id)->report->find("\"bytes\":42"), std::string::npos);
}

TEST_F(RedisJobStore, AReplicaWaitsOnAnothersRunAndTakesItsResult) {
  // A lease no pause of this test outlasts: B must find A meshing, never A's lease expired.
  limits_.reclaim_timeout = std::chrono::hours(1);
  a_ = std::make_unique<redis_job_store>(*records_a_, *lease_a_, *cache_a_, stats_a_, limits_);
  b_ = std::make_unique<redis_job_store>(*records_b_, *lease_b_, *cache_b_, stats_b_, limits_);
  progress_token token_a, token_b;
  ASSERT_TRUE(*a_->claim_run(stored_job_id, token_a));
  auto waiting = std::async(std::launch::async, [&] { return b_->claim_run(stored_job_id, token_b); });
  EXPECT_EQ(waiting.wait_for(100ms), std::future_status::timeout) << "B waits while A meshes";
  a_->renew_leases();  // A's heartbeat keeps its lease past the ttl
  ASSERT_TRUE(a_->complete(stored_job_id, sync_job(), tetrahedron(), std::make_shared<const std::string>("{}")).ok());
  a_->end_run(stored_job_id);
  const result<bool> claimed = waiting.get();
  ASSERT_TRUE(claimed.ok());
  EXPECT_FALSE(*claimed) << "B takes A's result instead of meshing";
  EXPECT_NE(b_->mesh(stored_job_id), nullptr);
  EXPECT_EQ(lease_a_->holder(stored_job_id)->has_value(), false) << "A released its lease";
}

TEST_F(RedisJobStore, TheLeaseOfADeadReplicaExpiresAndAnotherMeshes) {
  progress_token token_a, token_b;
  const auto started = std::chrono::steady_clock::now();  // before A's lease is set, so its whole ttl is after
  ASSERT_TRUE(*a_->claim_run(stored_job_id, token_a));  // A never renews nor releases: it died
  const result<bool> claimed = b_->claim_run(stored_job_id, token_b);
  ASSERT_TRUE(claimed.ok());
  EXPECT_TRUE(*claimed);
  EXPECT_GE(std::chrono::steady_clock::now() - started, 200ms) << "B waited for the lease to expire";
  EXPECT_EQ(**lease_b_->holder(stored_job_id), "B");
}

TEST_F(RedisJobStore, AWaitEndsWhenTheJobIsCancelled) {
  progress_token token_a, token_b;
  ASSERT_TRUE(*a_->claim_run(stored_job_id, token_a));
  token_b.cancel();
  const result<bool> claimed = b_->claim_run(stored_job_id, token_b);
  ASSERT_FALSE(claimed.ok());
  EXPECT_EQ(claimed.error().code(), errc::cancelled);
}

}  // namespace
}  // namespace tracemesh::server::test
