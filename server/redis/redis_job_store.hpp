#pragma once
/// @file redis_job_store.hpp
/// The job record store of a replica (`tracemeshd --store redis://…`; see job_record_store.hpp): records in Redis
/// (redis_job_records), each done job's certified mesh in the content-addressed result store on the directory every
/// replica mounts (result_cache: temp file + fsync + rename, checksummed; key "<id>.mesh"), so a mesh made by one
/// replica is found by every other; and a run lease per job (redis_run_lease), so that a job is meshed once
/// however many replicas are asked for it at the same time.
///
/// The shared result store is bounded by each replica's --cache-max-bytes over the entries it knows (LRU); a read
/// takes the whole entry into memory, so another replica's eviction never cuts a response short (the next request
/// finds the entry gone and, for a mesh, the job is meshed again).
///
/// Threading: thread-safe; every call may wait on Redis or the disk (workers and the prep pool only).

#include <chrono>
#include <mutex>
#include <set>
#include <string>

#include "server/storage/job_record_store.hpp"
#include "server/observability/metrics.hpp"
#include "server/redis/redis_job_records.hpp"
#include "server/redis/redis_run_lease.hpp"
#include "server/storage/result_cache.hpp"
#include "server/admission/server_limits.hpp"

namespace tracemesh::server {

/// The result-store key of a done job's certified mesh (serialize_mesh bytes).
std::string stored_mesh_key(const std::string& id);

class redis_job_store final : public job_record_store {
 public:
  /// All references must outlive this object; `limits.reclaim_timeout` is the run lease's time to live.
  redis_job_store(redis_job_records& records, redis_run_lease& lease, result_cache& results, metrics& stats,
                  replica_limits limits);

  std::optional<stored_job> find(const std::string& id) override;
  std::shared_ptr<const surface_mesh> mesh(const std::string& id) override;
  /// The mesh into the shared result store first (errc::io_error when it fails), then the record done in Redis
  /// (when Redis is away, the coordinator writes it with the job's final state once it is back).
  status complete(const std::string& id, const stored_job& record_if_new, const surface_mesh& mesh,
                  std::shared_ptr<const std::string> report) override;
  status record_encoding(const std::string& id, std::string_view format_name, const nlohmann::json& entry) override;
  /// Acquires the job's run lease; while another replica holds it, polls (limits.follow_poll) until the job is
  /// done with its mesh stored (false) or the lease is free again (that replica failed or died: this one takes
  /// it). When Redis cannot be
  /// asked, meshes without the lease (true): the result is content-addressed, a second run is only wasted time.
  result<bool> claim_run(const std::string& id, progress_token& token) override;
  void end_run(const std::string& id) override;
  /// Extends every lease this replica holds (the coordinator's heartbeat calls it).
  void renew_leases();

 private:
  /// True (counted as followed) when the job's record says done and its mesh is in the shared store.
  bool done_elsewhere(const std::string& id);

  redis_job_records& records_;
  redis_run_lease& lease_;
  result_cache& results_;
  metrics& stats_;
  const replica_limits limits_;
  std::mutex held_mutex_;
  std::set<std::string> held_;  // jobs whose run lease this replica holds
};

}  // namespace tracemesh::server
