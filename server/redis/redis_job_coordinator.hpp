#pragma once
/// @file redis_job_coordinator.hpp
/// The jobs of one replica of `tracemeshd --store redis://HOST:PORT[/DB]` (issue 13; see job_coordinator.hpp).
///
///   accept     one Lua script: the record (queued, its owner), the input, and an entry on the work stream
///              (XADD); a job queued or running anywhere only gains the owner (coalesced).
///   consumer   a thread that, while a general worker of this replica is free, takes one entry (XREADGROUP in the
///              consumer group), or takes over an entry whose replica stopped renewing it for the reclaim timeout
///              (XAUTOCLAIM), marks the record running here and submits the job to the local job queue. When the
///              job ends its final record is written and the entry acknowledged (XACK + XDEL); a job stopped by
///              this replica's shutdown stays pending for another replica to reclaim.
///   heartbeat  a thread that, every replica_limits::heartbeat: PINGs Redis (/readyz), renews this replica's stream
///              entries (XCLAIM JUSTID) and run leases, writes the progress of its jobs into their records (read by
///              GET /jobs/{id}; each change is published on the job-events channel), cancels a job an owner withdrew through
///              another replica, and retries final records that could not be written while Redis was away.
/// Any replica answers GET /jobs/{id}, its events and DELETE from the records. Its event streams read a record
/// when the replica's job-events subscriber (redis_job_events.hpp, started with the consumer) heard that the job
/// changed, or every replica_limits::event_fallback.
///
/// Redis down: accept answers 503, /readyz 503, the consumer takes nothing; running jobs finish and their final
/// records wait in memory until Redis is back (with AOF on, nothing accepted is lost). A replica killed mid-job:
/// its entry is reclaimed and its run lease expires after the reclaim timeout; another replica runs the job.

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/logger.h>

#include "server/jobs/job_coordinator.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/observability/metrics.hpp"
#include "server/redis/redis_client.hpp"
#include "server/redis/redis_job_events.hpp"
#include "server/redis/redis_job_records.hpp"
#include "server/redis/redis_job_store.hpp"
#include "server/redis/redis_run_lease.hpp"
#include "server/redis/redis_work_queue.hpp"
#include "server/storage/result_cache.hpp"
#include "server/admission/server_limits.hpp"

namespace tracemesh::server {

/// The Redis side of a replica: its connections, the records, the work stream, the run leases and the job record
/// store built on them. Built before the job queue (mesh_job_context needs `store`).
struct redis_replica {
  /// `results` is the shared result store; both references must outlive the replica.
  redis_replica(const redis_endpoint& endpoint, const server_config& config, result_cache& results, metrics& stats);

  const std::string name;
  const server_limits& limits;
  redis_client client;    ///< every short command
  redis_client blocking;  ///< XREADGROUP ... BLOCK only, so a blocked read never delays the others
  redis_job_records records;
  redis_job_events events;  ///< its own connection, subscribed to records.events_channel()
  redis_work_queue queue;  ///< on `client`
  redis_work_queue taker;  ///< on `blocking`: take() only
  redis_run_lease lease;
  redis_job_store store;
};

class redis_job_coordinator final : public job_coordinator {
 public:
  /// All references must outlive this object. `workers` is the number of general workers of `jobs`.
  redis_job_coordinator(redis_replica& replica, job_queue& jobs, unsigned workers, metrics& stats,
                        spdlog::logger& log);
  ~redis_job_coordinator() override;  ///< stops both threads; last try at the final records still unwritten

  /// Checks that Redis answers, creates the stream's consumer group and starts the consumer and the heartbeat.
  /// errc::io_error "Redis at … is unreachable" when it does not answer.
  status start() override;
  void stop() override;

  accept_result accept(const std::string& id, std::shared_ptr<const job_input> input,
                       const std::string& owner_hash) override;
  result<std::optional<job_snapshot>> find(const std::string& id) override;
  std::optional<job_snapshot> find_in_memory(const std::string& id) override { return jobs_.find(id); }
  withdraw_result withdraw(const std::string& id, const std::string& owner_hash) override;
  bool blocking_lookups() const override { return true; }
  std::optional<std::uint64_t> change_version(const std::string& id) const override {
    return replica_.events.version(id);
  }
  std::optional<std::string> unready_reason() const override;
  bool durable() const override { return true; }
  void add_gauges(metrics_gauges& gauges) const override {
    gauges.replica = replica_.name;
    gauges.redis_up = redis_up();
  }

  bool redis_up() const { return redis_up_.load(std::memory_order_relaxed); }

 private:
  /// A final state still to be written to Redis (and its stream entry acknowledged).
  struct pending_final {
    std::string id;
    std::string entry_id;
    job_state state = job_state::done;
    std::string error_code;
    std::string error_message;
    std::shared_ptr<const std::string> report;
  };

  void consumer_loop();
  /// The entries to run next: reclaimed ones when due and there are any, else new ones (waits up to take_block).
  result<std::vector<queue_entry>> next_entries(std::chrono::steady_clock::time_point& next_reclaim,
                                                bool& reclaimed);
  bool has_free_worker() const;
  void start_entry(const queue_entry& entry, bool reclaimed);
  std::shared_ptr<const job_input> load_input(const stored_job& record);
  void on_final(const std::string& entry_id, const job_snapshot& final_state, const job_output* output);
  bool write_final(const pending_final& final_state);
  void heartbeat_loop();
  void heartbeat_once();
  void note_redis(bool up);
  /// Waits up to `time` or until stop; false when stopping.
  bool pause(std::atomic<bool>& stopping, std::chrono::milliseconds time);

  redis_replica& replica_;
  job_queue& jobs_;
  const unsigned workers_;
  metrics& stats_;
  spdlog::logger& log_;
  const replica_limits limits_;

  std::atomic<bool> redis_up_{false};
  std::atomic<bool> consumer_stopping_{false};
  std::atomic<bool> heartbeat_stopping_{false};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::thread consumer_;
  std::thread heartbeat_;

  std::mutex mutex_;
  std::map<std::string, std::string> in_flight_;  // job id → stream entry id, for jobs this replica runs
  std::vector<pending_final> unwritten_;          // final records waiting for Redis
};

}  // namespace tracemesh::server
