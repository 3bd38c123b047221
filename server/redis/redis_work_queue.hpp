#pragma once
/// @file redis_work_queue.hpp
/// The queue shared by the replicas of `tracemeshd --store redis://…` (issue 13): a Redis Stream read through one
/// consumer group, so each accepted job is delivered to exactly one replica, and a job whose replica died is taken
/// over by another.
///
///   push      XADD <prefix>queue * job <id>                      (after the job's record is written)
///   take      XREADGROUP GROUP workers <replica> COUNT n BLOCK ms STREAMS <prefix>queue >
///   ack       XACK + XDEL                                         (after the job's final record is written)
///   reclaim   XAUTOCLAIM <prefix>queue workers <replica> <idle> 0 COUNT n
/// An entry taken but never acknowledged stays in the group's pending list; once it has been idle for the
/// reclaim timeout (its replica stopped renewing it: see touch()) another replica's reclaim() takes it. A running
/// replica calls touch() on its entries more often than the timeout, so a long meshing run is not taken over.
///
/// Entries are delivered at least once: the consumer checks the job's record (redis_job_records) and its run
/// lease (redis_run_lease) before meshing, and the content-addressed result store makes a second run harmless.

#include <chrono>
#include <string>
#include <vector>

#include "core/status.hpp"
#include "server/redis/redis_client.hpp"

namespace tracemesh::server {

/// One delivered queue entry.
struct queue_entry {
  std::string entry_id;  ///< the stream id ("1700000000000-0"), for ack() and touch()
  std::string job_id;
};

class redis_work_queue {
 public:
  /// `client` must outlive this object; `replica` names this replica's consumer (unique per process).
  redis_work_queue(redis_client& client, std::string replica, std::string key_prefix = "tracemesh:");

  /// Creates the stream and the consumer group when missing (a group that exists is fine).
  status ensure_group();
  /// Appends a job; returns its entry id.
  result<std::string> push(const std::string& job_id);
  /// Up to `count` new entries for this replica, waiting up to `block` for one (0 = do not wait). `block` must be
  /// shorter than redis_limits::command_timeout (errc::invalid_argument otherwise).
  result<std::vector<queue_entry>> take(std::size_t count, std::chrono::milliseconds block);
  /// Done with an entry (the job's final state is recorded): removes it from the pending list and the stream.
  status ack(const std::string& entry_id);
  /// Resets an entry's idle time (XCLAIM to this replica with JUSTID), so reclaim() elsewhere leaves it alone;
  /// false when the entry is no longer pending for this group (already acknowledged).
  result<bool> touch(const std::string& entry_id);
  /// Takes over up to `count` entries pending (delivered, not acknowledged) for at least `min_idle`.
  result<std::vector<queue_entry>> reclaim(std::chrono::milliseconds min_idle, std::size_t count);
  /// Entries delivered and not acknowledged, over all replicas.
  result<std::size_t> pending();

  const std::string& replica() const noexcept { return replica_; }
  std::string stream_key() const { return prefix_ + "queue"; }
  static constexpr const char* group = "workers";

 private:
  redis_client& client_;
  const std::string replica_;
  const std::string prefix_;
};

}  // namespace tracemesh::server
