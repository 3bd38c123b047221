#pragma once
/// @file metrics.hpp
/// Service metrics in the Prometheus text format (version 0.0.4): counters end in _total, every family has
/// # HELP and # TYPE, the job-seconds histogram has cumulative buckets ending in le="+Inf" equal to _count.
/// Thread-safe; counting is a mutex-protected map update or an atomic increment (cheap on the I/O threads).

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

namespace tracemesh::server {

/// Values owned elsewhere, sampled when /metrics is rendered.
struct metrics_gauges {
  std::size_t queue_depth = 0;
  std::size_t running_jobs = 0;
  std::size_t open_connections = 0;
  std::uint64_t cache_hits = 0;
  std::uint64_t cache_misses = 0;
  std::uint64_t cache_memory_bytes = 0;
  std::uint64_t cache_disk_bytes = 0;
  std::uint64_t cache_entries = 0;
  std::uint64_t cache_corrupt_entries = 0;
  std::uint64_t cache_evictions = 0;
  std::uint64_t cache_write_failures = 0;
  std::string replica;    ///< a replica's name (--store redis://…); empty: one process, no replica families
  bool redis_up = false;  ///< replicas: Redis answered the last heartbeat
};

class metrics {
 public:
  /// Upper bounds (seconds) of the job duration histogram buckets; +Inf is implicit.
  static constexpr std::array<double, 12> job_seconds_buckets{0.01, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300};

  /// One HTTP request answered on `route` (a route template such as "/jobs/{id}", never a raw path) with `status`.
  void count_request(std::string_view route, unsigned status);
  /// One real run of the mesher (coalesced and cached requests do not count).
  void count_mesher_run() { mesher_runs_.fetch_add(1, std::memory_order_relaxed); }
  /// A job reached a final state ("done", "failed", "cancelled") after `seconds` of work.
  void count_job_finished(std::string_view state, double seconds);
  /// A trace job whose mesh the lattice path made (mesh_output::fallback_reason): an engine failure to look into.
  void count_trace_fallback() { trace_fallbacks_.fetch_add(1, std::memory_order_relaxed); }
  /// `retries` trace attempts that failed and were made again on another line grid (trace_stats::grid_retries).
  void count_trace_grid_retries(std::size_t retries) {
    trace_grid_retries_.fetch_add(retries, std::memory_order_relaxed);
  }
  /// A response served from the result cache without running or waiting for a job.
  void count_cache_response() { cache_responses_.fetch_add(1, std::memory_order_relaxed); }
  /// A mesh encoding compressed for a response, with gzip (`brotli` false) or br.
  void count_mesh_compression(bool brotli) {
    (brotli ? br_compressions_ : gzip_compressions_).fetch_add(1, std::memory_order_relaxed);
  }

  /// A replica took a job from the shared stream: new (`reclaimed` false) or from a dead replica.
  void count_replica_job(bool reclaimed) {
    (reclaimed ? replica_reclaimed_ : replica_taken_).fetch_add(1, std::memory_order_relaxed);
  }
  /// A replica waited on another replica's run lease and found the job meshed there.
  void count_replica_followed() { replica_followed_.fetch_add(1, std::memory_order_relaxed); }

  std::uint64_t mesher_runs() const { return mesher_runs_.load(std::memory_order_relaxed); }
  std::uint64_t requests(std::string_view route, unsigned status) const;

  /// The whole exposition text.
  std::string render(const metrics_gauges& gauges) const;

 private:
  void render_replica(std::string& out, const metrics_gauges& gauges) const;

  mutable std::mutex mutex_;
  std::map<std::pair<std::string, unsigned>, std::uint64_t, std::less<>> requests_;
  std::map<std::string, std::uint64_t, std::less<>> jobs_finished_;
  std::array<std::uint64_t, job_seconds_buckets.size()> job_seconds_counts_{};  // per bucket, not cumulative
  std::uint64_t job_seconds_count_ = 0;
  double job_seconds_sum_ = 0;
  std::atomic<std::uint64_t> mesher_runs_{0};
  std::atomic<std::uint64_t> trace_fallbacks_{0};
  std::atomic<std::uint64_t> trace_grid_retries_{0};
  std::atomic<std::uint64_t> cache_responses_{0};
  std::atomic<std::uint64_t> gzip_compressions_{0};
  std::atomic<std::uint64_t> br_compressions_{0};
  std::atomic<std::uint64_t> replica_taken_{0};
  std::atomic<std::uint64_t> replica_reclaimed_{0};
  std::atomic<std::uint64_t> replica_followed_{0};
};

}  // namespace tracemesh::server
