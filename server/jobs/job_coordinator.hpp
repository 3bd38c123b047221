#pragma once
/// @file job_coordinator.hpp
/// Where the asynchronous jobs of POST /jobs live, as the API handlers see them: accepted (durably), looked up,
/// withdrawn by their owners. Two implementations:
///   local_job_coordinator  one process: the job store (local directory or memory) and this process's job queue;
///   redis_job_coordinator  replicas of `tracemeshd --store redis://…`: records and the work stream in Redis, jobs
///                          taken by whichever replica has a free worker, reclaimed when their replica dies.
/// Synchronous POST /mesh jobs run on the local job queue in both cases (the job record store's run claim keeps
/// replicas from meshing one job twice).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "core/status.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/storage/job_record_store.hpp"
#include "server/observability/metrics.hpp"

namespace tracemesh::server {

/// The outcome of accepting a POST /jobs submission.
struct accept_result {
  submit_outcome outcome = submit_outcome::shutting_down;
  job_snapshot snapshot;  ///< of the new or joined job (accepted, coalesced)
  status error;           ///< not ok: the job could not be recorded durably (answered 503, nothing accepted)
};

/// The outcome of an owner's DELETE.
struct withdraw_result {
  cancel_outcome outcome = cancel_outcome::not_found;
  /// The job after the withdrawal; for not_found and already_final, its final state when the records still know it.
  std::optional<job_snapshot> job;
  status error;  ///< not ok: the records cannot be reached (answered 503, nothing changed)
};

class job_coordinator {
 public:
  virtual ~job_coordinator() = default;

  /// Records job `id` (held by the owner token digest `owner_hash`) so that it survives this process, and queues it,
  /// or joins it when it is queued or running (coalesced). queue_full past limits.max_queue waiting jobs.
  virtual accept_result accept(const std::string& id, std::shared_ptr<const job_input> input,
                               const std::string& owner_hash) = 0;
  /// The job as GET /jobs/{id} shows it; std::nullopt when unknown; errc::io_error when the records cannot be read
  /// (the Redis store is unreachable). May block when blocking_lookups().
  virtual result<std::optional<job_snapshot>> find(const std::string& id) = 0;
  /// A job this process holds in memory (queued, running or recently finished here); never blocks.
  virtual std::optional<job_snapshot> find_in_memory(const std::string& id) = 0;
  /// Withdraws the owner `owner_hash`; the job is cancelled when it was its last holder (a running job stops at its
  /// next progress report, on whichever replica runs it).
  virtual withdraw_result withdraw(const std::string& id, const std::string& owner_hash) = 0;
  /// True when find() and withdraw() talk to the network (Redis): the handlers then call them off the I/O threads.
  virtual bool blocking_lookups() const = 0;
  /// Why this process should take no traffic now (e.g. "Redis is unreachable"), or std::nullopt.
  virtual std::optional<std::string> unready_reason() const = 0;
  /// Accepted jobs survive a restart of this process.
  virtual bool durable() const = 0;
  /// A number that changes whenever job `id` may have changed in the records (a message of the replica that runs
  /// it), for event streams that read the records only then (and at replica_limits::event_fallback);
  /// std::nullopt when there is no such signal now: read the records at every event interval.
  virtual std::optional<std::uint64_t> change_version(const std::string& /*id*/) const { return std::nullopt; }
  /// Adds what /metrics shows of the coordinator (a replica's name and Redis's state).
  virtual void add_gauges(metrics_gauges& /*gauges*/) const {}
  /// Starts what runs in the background (the Redis coordinator's consumer and heartbeat threads).
  virtual status start() { return status::success(); }
  /// Stops taking new work from shared queues; called before the job queue's shutdown. Idempotent.
  virtual void stop() {}
};

/// The record of a job accepted now (state queued) for `owner_hash`.
stored_job accepted_record(const std::string& id, const job_input& input, const std::string& owner_hash);

/// A job as the job store (or Redis) records it, as GET /jobs/{id} shows it.
job_snapshot snapshot_from_record(const stored_job& record);

}  // namespace tracemesh::server
