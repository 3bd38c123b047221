#pragma once
/// @file redis_run_lease.hpp
/// Cross-replica coalescing (issue 13): the same job id submitted to two replicas runs once. Before meshing, a
/// replica acquires the job's run lease, `SET <prefix>run:<id> <replica> NX PX <ttl>`; while it meshes it renews
/// the lease well within the ttl; when the job's final record is written it releases it. A replica that finds the
/// lease held by another does not mesh: it follows the job's record (and its progress messages) instead. A
/// replica that dies stops renewing, so its lease expires and the job can be run again by whoever reclaims it.
/// Renew and release are compare-and-set scripts: a replica never extends or deletes a lease it no longer holds.

#include <chrono>
#include <optional>
#include <string>

#include "core/status.hpp"
#include "server/redis/redis_client.hpp"

namespace tracemesh::server {

class redis_run_lease {
 public:
  /// `client` must outlive this object; `replica` is this replica's unique name.
  redis_run_lease(redis_client& client, std::string replica, std::string key_prefix = "tracemesh:");

  /// True when this replica now holds the job's lease for `ttl` (false: another replica holds it).
  result<bool> acquire(const std::string& job_id, std::chrono::milliseconds ttl);
  /// Extends this replica's lease to `ttl` from now; false when it does not hold it (expired, taken over).
  result<bool> renew(const std::string& job_id, std::chrono::milliseconds ttl);
  /// Gives the lease up; false when this replica did not hold it.
  result<bool> release(const std::string& job_id);
  /// The replica holding the lease, or std::nullopt when none does.
  result<std::optional<std::string>> holder(const std::string& job_id);

  std::string lease_key(const std::string& job_id) const { return prefix_ + "run:" + job_id; }

 private:
  redis_client& client_;
  const std::string replica_;
  const std::string prefix_;
};

}  // namespace tracemesh::server
