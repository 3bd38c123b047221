#pragma once
/// @file api_handlers.hpp
/// The routes of tracemeshd (proto/openapi.json) on top of the HTTP transport:
///   POST /mesh                 upload → mesh bytes (waits for the job without holding an I/O thread)
///   POST /jobs                 upload → 202 {id, status, links} (200 when the result is already cached)
///   GET|HEAD|DELETE /jobs/{id} job status JSON (the job store answers for finished jobs within retention) /
///                              withdraw the owner of X-Job-Token (401 without it, 403 for a stranger's; the job is
///                              cancelled when its last holder withdrew; 409 when it already finished)
///   GET /jobs/{id}/events      Server-Sent Events: progress (at connect and on change, ≤ ~4/s), then one done or
///                              error event with the job document, then the stream closes
///   GET|HEAD /jobs/{id}/mesh   ?format=off|draco (default: the job's submitted format, else off), ETag /
///                              If-None-Match → 304, 409 while the job has no mesh; Accept-Encoding → br/gzip for
///                              compressible formats (compressed once, cached; 406 when identity is refused and
///                              nothing else fits); one Range (If-Range) of the selected bytes → 206 / 416
///   GET|HEAD /healthz /readyz /metrics /openapi.json; OPTIONS on every route (CORS preflight)
/// Threads: plan() and the cheap handlers run on I/O threads; small uploads' parsing, job-id hashing and every disk
/// cache read run on the prep pool; decompression and parsing of large or gzip-encoded uploads on the
/// large-upload pool (so a cache hit never waits behind them); meshing runs on the job queue's workers.
/// Per client (bearer token, else IP address): uploads in flight, jobs queued or running and event streams open
/// are bounded (max_uploads_per_client, max_jobs_per_client, max_event_streams_per_client → 429 client_limit).

#include <cstddef>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/thread_pool.hpp>
#include <spdlog/logger.h>

#include "proto/mesh_format.hpp"
#include "server/admission/access_tokens.hpp"
#include "server/admission/client_quota.hpp"
#include "server/http/http_server.hpp"
#include "server/jobs/job_coordinator.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/storage/job_store.hpp"
#include "server/jobs/mesh_job.hpp"
#include "server/observability/log_throttle.hpp"
#include "server/observability/metrics.hpp"
#include "server/storage/result_cache.hpp"
#include "server/admission/server_limits.hpp"
#include "server/admission/upload_admission.hpp"

namespace tracemesh::server {

/// What the handlers use; owned by the service, all outliving the handlers' last call.
struct api_dependencies {
  const server_config& config;
  job_queue& jobs;
  result_cache& cache;
  job_coordinator& coordinator;  ///< POST /jobs jobs: accepted, looked up, withdrawn (local or Redis)
  const mesh_job_context& results;  ///< encodes stored meshes on demand (encoded_result)
  const bearer_tokens& auth;        ///< empty: no bearer authentication
  metrics& stats;
  spdlog::logger& log;
  http_server_state& state;
  const cors_policy& cors;
  boost::asio::thread_pool& prep;  ///< small uploads' parsing, hashing, disk cache reads
  /// Decompression and parsing of uploads over limits.large_upload_bytes and of gzip-encoded ones, so that
  /// small uploads and cache reads on `prep` never wait behind them.
  boost::asio::thread_pool& large_uploads;
};

class api_handlers final : public request_handler {
 public:
  explicit api_handlers(api_dependencies deps);

  std::variant<reply, body_plan> plan(const request_head& head, const std::string& client_address) override;
  void handle(const request_head& head, const body_plan& plan, std::string body, reply_sink done) override;
  void handle_upload(const request_head& head, body_plan plan, std::vector<multipart_part> parts,
                     reply_sink done) override;
  /// Decodes the gzip body on the prep pool (under limits.max_pqr_bytes, as a gzipped PQR file), parses it as
  /// multipart/form-data, then continues as handle_upload.
  void handle_encoded_upload(const request_head& head, body_plan plan, std::string compressed_body,
                             reply_sink done) override;
  bool is_health_route(std::string_view target) const override;

  /// Uploads being received or prepared now, and the body bytes they hold (bounded by max_concurrent_uploads
  /// and max_upload_bytes_in_flight).
  const upload_admission& uploads() const { return uploads_; }

 private:
  struct upload_request;

  reply metrics_reply() const;
  reply readiness_reply() const;
  /// Runs `lookup` here, or on the prep pool when the coordinator's lookups block (Redis).
  void off_io_thread_if_blocking(std::function<void()> lookup);
  /// 503 + Retry-After (logged): the job records cannot be read now.
  reply records_unreachable_reply(const status& error, std::string route) const;
  void job_status(const std::string& id, reply_sink done);
  /// GET /jobs/{id}/events: 404 for an unknown job, 429 past limits.max_event_streams_per_client for `client`,
  /// 503 past limits.max_event_streams, else the event stream.
  void job_events(const std::string& id, const std::string& client, reply_sink done);
  /// The warning that `client` was refused by the per-client limit `limit_name` (at most one per client per
  /// limits.refusal_log_interval).
  void log_client_refusal(const std::string& client, std::string_view limit_name, std::string_view route);
  void cancel_job(const std::string& id, const std::string& owner_token, reply_sink done);
  std::optional<reply> authorization_failure(const request_head& head, const char* route) const;
  /// The error line of a done job whose stored mesh the job store cannot give back any more.
  void log_result_lost(const std::string& id, proto::mesh_format format, const std::string& reason);
  void job_mesh(const request_head& head, const std::string& id, std::optional<proto::mesh_format> format,
                reply_sink done);
  /// GET /jobs/{id}/mesh in `format` (`requested`: the URL named it); `job`: the queue's snapshot, when it has one.
  void job_mesh_in(const request_head& head, const std::string& id, proto::mesh_format format, bool requested,
                   std::optional<job_snapshot> job, reply_sink done);
  void prepare_upload(std::shared_ptr<upload_request> upload);  // on the prep pool
  void submit_job(std::shared_ptr<upload_request> upload, const std::string& id, std::size_t atoms);
  /// The pool that parses an upload of `body_bytes` (gzip-encoded ones always take the large-upload pool).
  boost::asio::thread_pool& parsing_pool(std::size_t body_bytes, bool gzip_encoded) const;
  /// The per-client key of a request: its bearer token's digest when the server authenticates, else its IP.
  std::string client_key(const request_head& head, const std::string& client_address) const;

  api_dependencies deps_;
  upload_admission uploads_;
  client_quota client_uploads_;
  client_quota client_jobs_;
  client_quota client_event_streams_;
  log_throttle refusal_log_;
};

}  // namespace tracemesh::server
