#pragma once
// Two "replicas" (two clients, as two tracemeshd processes would hold) sharing one real redis-server.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>

#include "server/storage/job_store.hpp"
#include "support/redis_process.hpp"

namespace tracemesh::server::test {

/// A job record as POST /jobs accepts it (state queued, one owner).
inline stored_job queued_job(const std::string& id) {
  stored_job record;
  record.id = id;
  record.state = job_state::queued;
  record.parameters = "density=2;d=-1;t0=1";
  record.format = proto::mesh_format::glb;
  record.owners = {std::string(64, 'a')};
  record.accepted_ms = unix_millis();
  return record;
}

class SharedRedis : public ::testing::Test {
 protected:
  void SetUp() override {
    TRACEMESH_REQUIRE_REDIS_SERVER();
    ASSERT_TRUE(redis_.start());
    replica_a_ = std::make_unique<redis_client>(redis_.endpoint(), limits());
    replica_b_ = std::make_unique<redis_client>(redis_.endpoint(), limits());
    ASSERT_TRUE(replica_a_->connect().ok());
    ASSERT_TRUE(replica_b_->connect().ok());
  }
  static redis_limits limits() {
    redis_limits limits;
    limits.connect_timeout = std::chrono::milliseconds(500);
    limits.command_timeout = std::chrono::seconds(2);
    return limits;
  }
  testing::redis_process redis_;
  std::unique_ptr<redis_client> replica_a_;
  std::unique_ptr<redis_client> replica_b_;
};

}  // namespace tracemesh::server::test
