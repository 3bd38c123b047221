#include "server/service.hpp"

#include <algorithm>
#include <chrono>

#include "server/jobs/local_job_coordinator.hpp"
#include "server/observability/logging.hpp"

namespace tracemesh::server {

namespace {

/// After the jobs are settled, how long in-flight responses (e.g. the replies of cancelled synchronous jobs) get
/// to be written before the I/O threads stop.
constexpr std::chrono::milliseconds response_flush_time{2000};

mesher_function default_mesher(mesher_function mesher) {
  if (mesher) return mesher;
  mesher_function production = [](const molecule& mol, const mesh_params& params, const mesh_limits& limits,
                                  progress_token& token) { return mesh_molecule(mol, params, limits, token); };
  if (wrap_mesher_for_tests != nullptr) return wrap_mesher_for_tests(std::move(production));  // service.hpp: why
  return production;
}

job_queue_options queue_options(const server_config& config) {
  job_queue_options options;
  options.workers = std::max(1u, config.workers);
  options.max_queue = config.limits.max_queue;
  options.max_records = config.limits.max_job_records;
  options.job_timeout = config.limits.job_timeout;
  options.small_job_workers = config.small_job_workers;
  options.small_job_max_atoms = config.limits.small_job_max_atoms;
  return options;
}

/// This replica's Redis side with --store redis://…; null for one process alone (or a malformed URL: start()
/// reports it).
std::unique_ptr<redis_replica> make_replica(const server_config& config, result_cache& results, metrics& stats) {
  if (config.store_url.empty()) return nullptr;
  result<redis_endpoint> endpoint = parse_redis_url(config.store_url);
  if (!endpoint.ok()) return nullptr;
  return std::make_unique<redis_replica>(*endpoint, config, results, stats);
}

job_record_store& record_store(const std::unique_ptr<redis_replica>& replica, job_store& local) {
  if (replica) return replica->store;
  return local;
}

std::unique_ptr<job_coordinator> make_coordinator(const std::unique_ptr<redis_replica>& replica, job_queue& jobs,
                                                  job_store& local, const server_config& config, metrics& stats,
                                                  spdlog::logger& log) {
  if (replica) return std::make_unique<redis_job_coordinator>(*replica, jobs, config.workers, stats, log);
  return std::make_unique<local_job_coordinator>(jobs, local);
}

}  // namespace

service::service(server_config config, std::shared_ptr<spdlog::logger> log, mesher_function mesher)
    : config_(std::move(config)),
      log_(std::move(log)),
      state_(config_.limits.max_connections_per_client),
      cors_(config_.cors_origins),
      cache_(config_.cache_dir, cache_limits{config_.limits.cache_memory_bytes, config_.limits.cache_disk_bytes}),
      store_(job_store_options{config_.job_dir, config_.limits.job_retention, config_.limits.job_store_memory_bytes}),
      redis_(make_replica(config_, cache_, metrics_)),
      mesh_context_{cache_,         record_store(redis_, store_), metrics_, *log_, config_.limits.mesh,
                    config_.mesher_threads, default_mesher(std::move(mesher))},
      jobs_(queue_options(config_),
            [this](const std::string& id, const job_input& input, progress_token& token) {
              return run_mesh_job(mesh_context_, id, input, token);
            },
            metrics_, [this](const job_snapshot& final_state, const job_output*) { record_final(final_state); }),
      coordinator_(make_coordinator(redis_, jobs_, store_, config_, metrics_, *log_)),
      prep_(std::max(1u, config_.prep_threads)),
      large_uploads_(std::max(1u, config_.large_upload_threads)),
      api_(api_dependencies{config_, jobs_, cache_, *coordinator_, mesh_context_, auth_, metrics_, *log_, state_, cors_,
                            prep_, large_uploads_}),
      http_context_{config_.limits, api_, state_, metrics_, *log_, cors_} {
  cache_.set_corruption_listener([log = log_](const std::string& key, const char* reason) {
    log_event(*log, spdlog::level::err, "cache_corrupt", {{"key", key}, {"reason", reason}, {"action", "removed"}});
  });
}

service::~service() { shutdown(); }

// Failed and cancelled jobs are recorded in the store; done jobs were stored by their work. A job stopped by the
// shutdown stays queued in the store: it runs again at the next start.
void service::record_final(const job_snapshot& final_state) {
  if (final_state.state == job_state::done || final_state.error_code == job_error::shutdown) return;
  const status recorded =
      store_.finish(final_state.id, final_state.state, final_state.error_code, final_state.error.message());
  if (!recorded.ok()) {
    log_event(*log_, spdlog::level::err, "job_store_write_failed",
              {{"job", final_state.id}, {"error", recorded.message()}});
  }
}

void service::requeue_unfinished() {
  for (const std::string& id : store_.take_lost()) {
    log_event(*log_, spdlog::level::err, "job_lost",
              {{"job", id}, {"error", "its stored input or record was damaged; the job ends failed (lost)"}});
  }
  std::size_t requeued = 0;
  for (unfinished_job& unfinished : store_.take_unfinished()) {
    submit_options how;
    how.recovered = true;
    for (const std::string& owner : unfinished.record.owners) {
      jobs_.submit(unfinished.record.id, unfinished.input, {}, submit_options{job_holder{owner}, true});
    }
    if (unfinished.record.owners.empty()) jobs_.submit(unfinished.record.id, unfinished.input, {}, how);
    ++requeued;
  }
  if (requeued > 0) log_event(*log_, spdlog::level::info, "jobs_requeued", {{"jobs", requeued}});
}

status service::start() {
  if (!config_.cache_dir.empty()) {
    const status opened = cache_.open();
    if (!opened.ok()) return opened;
  }
  if (const status opened = store_.open(); !opened.ok()) return opened;
  if (!config_.auth_token_file.empty()) {
    result<bearer_tokens> tokens = bearer_tokens::from_file(config_.auth_token_file);
    if (!tokens.ok()) return tokens.error();
    auth_ = std::move(*tokens);
  }
  if (!config_.store_url.empty()) {
    if (result<redis_endpoint> endpoint = parse_redis_url(config_.store_url); !endpoint.ok()) return endpoint.error();
    if (config_.cache_dir.empty()) {
      return status(errc::invalid_argument, "--store redis://… needs --cache-dir: the result directory every "
                                            "replica mounts");
    }
  }
  if (const status started = coordinator_->start(); !started.ok()) return started;
  requeue_unfinished();
  listener_ = std::make_shared<http_listener>(io_, http_context_);
  const status listening = listener_->open(config_.listen_host, config_.listen_port);
  if (!listening.ok()) return listening;
  listener_->run();
  io_work_.emplace(io_.get_executor());
  const unsigned threads = std::max(1u, config_.io_threads);
  for (unsigned i = 0; i < threads; ++i) io_threads_.emplace_back([this] { io_.run(); });
  running_ = true;
  nlohmann::json settings = config_to_json(config_);
  settings["port"] = listener_->port();
  settings["engine_version"] = engine_version;
  log_event(*log_, spdlog::level::info, "started", settings);
  if (!store_.durable()) {
    log_event(*log_, spdlog::level::warn, "no_disk_store",
              {{"message", "jobs and results are kept in memory only: a restart loses them"}});
  }
  return status::success();
}

void service::shutdown() {
  if (!running_) {
    jobs_.shutdown(std::chrono::milliseconds(0));
    return;
  }
  running_ = false;
  const auto started = std::chrono::steady_clock::now();
  log_event(*log_, spdlog::level::info, "shutdown_started",
            {{"queued", jobs_.queue_depth()}, {"running", jobs_.running_jobs()}});
  state_.draining.store(true);
  listener_->stop();
  coordinator_->stop();  // a replica takes no more work from the shared stream
  jobs_.shutdown(config_.limits.shutdown_grace);
  const auto flush_deadline = std::chrono::steady_clock::now() + response_flush_time;
  while (state_.busy_requests.load() > 0 && std::chrono::steady_clock::now() < flush_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  io_work_.reset();
  io_.stop();
  for (auto& thread : io_threads_) thread.join();
  io_threads_.clear();
  large_uploads_.join();
  prep_.join();
  log_event(*log_, spdlog::level::info, "shutdown_done",
            {{"seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()}});
}

}  // namespace tracemesh::server
