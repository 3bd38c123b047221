#pragma once
/// @file service.hpp
/// tracemeshd as an object: wires the result cache, the job queue and its workers, the prep and large-upload
/// pools, the API handlers and the HTTP listener with its I/O threads. main() runs one; tests can run one in-process with a fake
/// mesher.

#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/thread_pool.hpp>
#include <spdlog/logger.h>

#include "server/api/api_handlers.hpp"
#include "server/admission/access_tokens.hpp"
#include "server/http/http_server.hpp"
#include "server/jobs/job_coordinator.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/storage/job_store.hpp"
#include "server/jobs/mesh_job.hpp"
#include "server/observability/metrics.hpp"
#include "server/redis/redis_job_coordinator.hpp"
#include "server/storage/result_cache.hpp"
#include "server/admission/server_limits.hpp"

namespace tracemesh::server {

/// Test-only seam: when a program defines it, the service's default mesher is what it returns for
/// tracemesh::mesh_molecule. Only tests/support/held_mesher_hook.cpp defines it, linked only into the test program
/// tracemeshd_testable (tests/CMakeLists.txt), where it holds chosen jobs until the test lets them go. The
/// production tracemeshd does not define it: the weak symbol is null there, so no flag or environment variable can
/// reach the hook.
[[gnu::weak]] mesher_function wrap_mesher_for_tests(mesher_function mesher);

class service {
 public:
  /// Nothing runs until start(). `mesher` defaults to tracemesh::mesh_molecule.
  service(server_config config, std::shared_ptr<spdlog::logger> log, mesher_function mesher = {});
  ~service();  ///< shutdown() if still running
  service(const service&) = delete;
  service& operator=(const service&) = delete;

  /// Opens the cache and the job store (errc::io_error, one line, when a directory is not a writable directory),
  /// reads the bearer tokens, queues again the jobs the store had accepted and not finished, binds the listener
  /// (errc::io_error when the address is taken, errc::invalid_argument when malformed) and starts the I/O
  /// threads. Logs the settings.
  status start();
  /// The bound port (useful with listen_port 0).
  unsigned short port() const { return listener_ ? listener_->port() : 0; }

  /// Graceful stop: refuse new uploads and connections, /readyz → 503, let jobs finish for up to
  /// limits.shutdown_grace then cancel the rest, let in-flight responses go out, stop the threads. Idempotent.
  void shutdown();

  metrics& stats() { return metrics_; }
  job_queue& jobs() { return jobs_; }
  result_cache& cache() { return cache_; }
  job_store& store() { return store_; }
  job_coordinator& coordinator() { return *coordinator_; }
  /// Uploads in flight and the body bytes they hold.
  const upload_admission& uploads() const { return api_.uploads(); }
  /// Open connections and requests being served.
  const http_server_state& http_state() const { return state_; }

 private:
  server_config config_;
  std::shared_ptr<spdlog::logger> log_;
  metrics metrics_;
  http_server_state state_;
  cors_policy cors_;
  result_cache cache_;
  job_store store_;
  bearer_tokens auth_;
  // --store redis://…: this replica's Redis side (null for one process alone), built before the work that uses it.
  std::unique_ptr<redis_replica> redis_;
  mesh_job_context mesh_context_;
  job_queue jobs_;
  std::unique_ptr<job_coordinator> coordinator_;  // local_job_coordinator or redis_job_coordinator
  boost::asio::thread_pool prep_;
  boost::asio::thread_pool large_uploads_;
  api_handlers api_;
  http_context http_context_;
  boost::asio::io_context io_;
  // Keeps the I/O threads running while sessions wait for jobs with no socket operation pending (e.g. during
  // shutdown, after the acceptor closed).
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> io_work_;
  std::shared_ptr<http_listener> listener_;
  std::vector<std::thread> io_threads_;
  bool running_ = false;

  void record_final(const job_snapshot& final_state);
  void requeue_unfinished();
};

}  // namespace tracemesh::server
