// tracemeshd — the tracemesh meshing service. See server/service.hpp and `tracemeshd --help`.
#include <csignal>
#include <cstdio>
#include <thread>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>

#include "core/tbb_under_thread_sanitizer.hpp"
#include "server/observability/logging.hpp"
#include "server/redis/redis_url.hpp"
#include "server/service.hpp"
#include "tracemesh_build_info.hpp"

namespace {

using tracemesh::server::server_config;

std::chrono::milliseconds to_millis(double seconds) {
  return std::chrono::milliseconds(static_cast<long long>(seconds * 1000.0));
}

double seconds_of(std::chrono::milliseconds time) { return static_cast<double>(time.count()) / 1000.0; }

/// "<hostname>-<pid>": unique among the replicas of one group while they run.
std::string default_replica_name() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0 || host[0] == '\0') std::snprintf(host, sizeof host, "replica");
  return std::string(host) + "-" + std::to_string(::getpid());
}

struct command_line {
  server_config config;
  std::string log_level = "info";
};

/// Fills `line` from argv; returns an exit code when the program should stop (help, errors).
std::optional<int> parse_command_line(int argc, char** argv, command_line& line) {
  server_config& config = line.config;
  tracemesh::server::server_limits& limits = config.limits;
  const tracemesh::server::server_limits defaults;
  CLI::App app{"tracemeshd: meshes molecular Gaussian surfaces over HTTP (POST /mesh, /jobs; see /openapi.json)"};

  std::string listen = config.listen_host + ":" + std::to_string(config.listen_port);
  std::string cache_dir, job_dir, auth_token_file;
  bool no_disk_store = false;
  double job_retention = 86400;
  std::vector<std::string> auth_exempt;
  std::size_t max_atoms = limits.mesh.max_atoms;
  std::uint64_t max_upload_bytes = 0;
  double job_timeout = 600, header_timeout = 30, request_timeout = 300, write_timeout = 60, shutdown_grace = 20;
  double upload_rate_grace = 10;
  std::vector<std::string> cors_origins;
  std::vector<std::string> trusted_proxies;

  app.add_option("--listen", listen, "Address and port to listen on (host:port; port 0 = any free port)")
      ->capture_default_str();
  app.add_option("--workers", config.workers, "Jobs meshed at the same time (worker threads)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 256u));
  app.add_option("--mesher-threads", config.mesher_threads, "Threads inside one mesher run (0 = all cores)")
      ->capture_default_str();
  app.add_option("--io-threads", config.io_threads, "HTTP I/O threads")->capture_default_str()->check(
      CLI::Range(1u, 64u));
  app.add_option("--prep-threads", config.prep_threads, "Threads parsing uploads and reading the disk cache")
      ->capture_default_str()
      ->check(CLI::Range(1u, 64u));
  app.add_option("--cache-dir", cache_dir,
                 "Result cache directory; accepted jobs and their meshes are kept in <cache-dir>/jobs unless "
                 "--job-dir is given. Required unless --no-disk-store");
  app.add_option("--job-dir", job_dir, "Job store directory (records, inputs of unfinished jobs, meshes)");
  app.add_flag("--no-disk-store", no_disk_store,
               "Keep the cache and the jobs in memory only: a restart loses accepted jobs (/readyz says so)");
  app.add_option("--job-retention", job_retention,
                 "Seconds a finished job's record and mesh are kept after it ended")
      ->capture_default_str();
  app.add_option("--job-store-memory-bytes", limits.job_store_memory_bytes,
                 "With --no-disk-store: bytes of meshes the in-memory job store holds")
      ->capture_default_str();
  app.add_option("--auth-token-file", auth_token_file,
                 "File of bearer tokens (one per line): every route but the exempt ones then needs "
                 "'Authorization: Bearer <token>'");
  app.add_option("--auth-exempt", auth_exempt,
                 "Route answered without a bearer token; repeat for several (default: /healthz /readyz /metrics; "
                 "'none' = no exemption)");
  app.add_option("--cache-max-bytes", limits.cache_disk_bytes, "Disk bytes of the result cache")->capture_default_str();
  app.add_option("--cache-memory-bytes", limits.cache_memory_bytes, "Memory bytes of the result cache")
      ->capture_default_str();
  app.add_option("--max-atoms", max_atoms, "Atoms accepted in one upload")->capture_default_str();
  app.add_option("--max-upload-bytes", max_upload_bytes,
                 "Request body bytes of an upload (default: 128 bytes per allowed atom + 64 KiB)");
  app.add_option("--max-queue", limits.max_queue, "Jobs waiting for a worker before uploads get 429")
      ->capture_default_str();
  app.add_option("--max-connections", limits.max_connections,
                 "Open connections; one more closes the oldest idle keep-alive connection, else gets 503")
      ->capture_default_str();
  app.add_option("--health-connection-reserve", limits.health_connection_reserve,
                 "Connections over --max-connections or --max-connections-per-client that may still ask /healthz "
                 "or /readyz (a new one closes the oldest that sent nothing)")
      ->capture_default_str();
  app.add_option("--max-event-streams", limits.max_event_streams,
                 "GET /jobs/{id}/events streams open at once; more get 503")
      ->capture_default_str();
  app.add_option("--max-event-streams-per-client", limits.max_event_streams_per_client,
                 "GET /jobs/{id}/events streams of one client open at once; more get 429")
      ->capture_default_str();
  app.add_option("--max-concurrent-uploads", limits.max_concurrent_uploads,
                 "Uploads received or parsed at the same time; more get 429")
      ->capture_default_str();
  app.add_option("--max-upload-bytes-in-flight", limits.max_upload_bytes_in_flight,
                 "Body bytes of all uploads received or parsed at the same time; more get 429")
      ->capture_default_str();
  app.add_option("--min-upload-rate", limits.min_upload_bytes_per_second,
                 "Bytes per second an upload body must average after --upload-rate-grace, else 408 (0 = off)")
      ->capture_default_str();
  app.add_option("--upload-rate-grace", upload_rate_grace,
                 "Seconds after the request header before --min-upload-rate applies")
      ->capture_default_str();
  app.add_option("--large-upload-bytes", limits.large_upload_bytes,
                 "Uploads larger than this (and gzip-encoded ones) are decoded on the large-upload threads")
      ->capture_default_str();
  app.add_option("--large-upload-threads", config.large_upload_threads,
                 "Threads decompressing and parsing large uploads (bounded: more wait their turn)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 64u));
  app.add_option("--max-connections-per-client", limits.max_connections_per_client,
                 "Open connections of one client (bearer token, else IP); more get 429 (health routes answer)")
      ->capture_default_str();
  app.add_option("--max-uploads-per-client", limits.max_uploads_per_client,
                 "Uploads of one client received or parsed at the same time; more get 429")
      ->capture_default_str();
  app.add_option("--max-jobs-per-client", limits.max_jobs_per_client,
                 "Jobs of one client queued or running; more get 429")
      ->capture_default_str();
  app.add_option("--trusted-proxy", trusted_proxies,
                 "Reverse proxy network (CIDR, IPv4 or IPv6; repeat or comma-separate): from these peers the client "
                 "is taken from Forwarded / X-Forwarded-For (default: none, the headers are ignored)");
  app.add_option("--small-job-max-atoms", limits.small_job_max_atoms,
                 "Jobs of at most this many atoms may run on the workers reserved for small jobs")
      ->capture_default_str();
  app.add_option("--small-job-workers", config.small_job_workers,
                 "Workers reserved for small jobs, besides --workers (0 = none)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 64u));
  app.add_option("--job-timeout", job_timeout, "Seconds a job may run before it fails with \"timeout\"")
      ->capture_default_str();
  app.add_option("--header-timeout", header_timeout,
                 "Seconds to receive a request header (also the keep-alive idle timeout)")
      ->capture_default_str();
  app.add_option("--request-timeout", request_timeout, "Seconds to receive a whole request (header and body)")
      ->capture_default_str();
  app.add_option("--write-timeout", write_timeout, "Seconds to write one response")->capture_default_str();
  app.add_option("--shutdown-grace", shutdown_grace,
                 "Seconds jobs may still run after SIGTERM before they are cancelled")
      ->capture_default_str();
  double reclaim_timeout = seconds_of(limits.replicas.reclaim_timeout);
  app.add_option("--store", config.store_url,
                 "Where jobs are coordinated: omit for this process alone (the local job store); "
                 "redis://HOST:PORT[/DB] makes this process one replica of many that share job records and work "
                 "through Redis and results through --cache-dir (a directory every replica mounts)");
  app.add_option("--replica-name", config.replica_name,
                 "With --store: this replica's name in Redis and in /metrics (default <hostname>-<pid>; unique)");
  app.add_option("--reclaim-timeout", reclaim_timeout,
                 "With --store: seconds after which a job whose replica stopped renewing it (died) is taken over")
      ->capture_default_str();
  app.add_option("--cors-origin", cors_origins, "Allowed CORS origin; repeat for several; \"*\" = any (default)");
  app.add_option("--log-level", line.log_level, "trace, debug, info, warn, error, critical or off")
      ->capture_default_str();
  app.set_version_flag("--version", tracemesh::build_info::version_line("tracemeshd"));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error);
  }

  const auto networks = tracemesh::server::parse_networks(trusted_proxies);
  if (!networks.ok()) {
    std::fprintf(stderr, "tracemeshd: --trusted-proxy: %s\n", networks.error().message().c_str());
    return 2;
  }
  limits.trusted_proxies = *networks;
  if (!tracemesh::server::parse_listen_address(listen, config)) {
    std::fprintf(stderr, "tracemeshd: --listen expects host:port, got '%s'\n", listen.c_str());
    return 2;
  }
  const double timeouts[] = {job_timeout, header_timeout, request_timeout, write_timeout};
  for (double seconds : timeouts) {
    if (!(seconds > 0) || seconds > 1e7) {
      std::fprintf(stderr, "tracemeshd: timeouts must be positive numbers of seconds\n");
      return 2;
    }
  }
  if (!(upload_rate_grace >= 0) || upload_rate_grace > 1e7) {
    std::fprintf(stderr, "tracemeshd: --upload-rate-grace must be >= 0 seconds\n");
    return 2;
  }
  if (!(shutdown_grace >= 0) || shutdown_grace > 1e7 || max_atoms == 0) {
    std::fprintf(stderr, "tracemeshd: --shutdown-grace must be >= 0 and --max-atoms > 0\n");
    return 2;
  }
  if (no_disk_store && (!cache_dir.empty() || !job_dir.empty())) {
    std::fprintf(stderr, "tracemeshd: --no-disk-store cannot be combined with --cache-dir or --job-dir\n");
    return 2;
  }
  if (!no_disk_store && cache_dir.empty()) {
    std::fprintf(stderr,
                 "tracemeshd: give --cache-dir DIR (accepted jobs and results survive restarts) or --no-disk-store\n");
    return 2;
  }
  if (!(job_retention > 0) || job_retention > 1e9) {
    std::fprintf(stderr, "tracemeshd: --job-retention must be a positive number of seconds\n");
    return 2;
  }
  if (!config.store_url.empty()) {
    if (const auto endpoint = tracemesh::server::parse_redis_url(config.store_url); !endpoint.ok()) {
      std::fprintf(stderr, "tracemeshd: --store: %s\n", endpoint.error().message().c_str());
      return 2;
    }
    if (cache_dir.empty() || !job_dir.empty()) {
      std::fprintf(stderr, "tracemeshd: --store redis://… needs --cache-dir (the result directory every replica "
                           "mounts) and takes no --job-dir (job records live in Redis)\n");
      return 2;
    }
    if (!(reclaim_timeout >= 0.1) || reclaim_timeout > 1e6) {
      std::fprintf(stderr, "tracemeshd: --reclaim-timeout must be at least 0.1 seconds\n");
      return 2;
    }
    limits.replicas.reclaim_timeout = to_millis(reclaim_timeout);
    // Renewals several times per reclaim timeout, so a live replica's jobs are never taken over.
    limits.replicas.heartbeat = std::min(limits.replicas.heartbeat, limits.replicas.reclaim_timeout / 4);
    if (config.replica_name.empty()) config.replica_name = default_replica_name();
  }
  config.cache_dir = cache_dir;
  config.job_dir = !job_dir.empty() ? std::filesystem::path(job_dir)
                   : cache_dir.empty() || !config.store_url.empty() ? std::filesystem::path()
                                                                     : std::filesystem::path(cache_dir) / "jobs";
  config.auth_token_file = auth_token_file;
  if (!auth_exempt.empty()) {
    config.auth_exempt_routes.clear();
    for (const std::string& route : auth_exempt) {
      if (route != "none") config.auth_exempt_routes.push_back(route);
    }
  }
  limits.job_retention = to_millis(job_retention);
  if (!cors_origins.empty()) config.cors_origins = cors_origins;
  limits.mesh.max_atoms = max_atoms;
  limits.max_upload_bytes =
      max_upload_bytes > 0 ? max_upload_bytes : tracemesh::server::upload_limit_for_atoms(max_atoms);
  limits.max_pqr_bytes = tracemesh::max_pqr_text_bytes(limits.mesh);
  limits.job_timeout = to_millis(job_timeout);
  limits.header_timeout = to_millis(header_timeout);
  limits.request_timeout = to_millis(request_timeout);
  limits.write_timeout = to_millis(write_timeout);
  limits.shutdown_grace = to_millis(shutdown_grace);
  limits.upload_rate_grace = to_millis(upload_rate_grace);
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  command_line line;
  if (auto exit_code = parse_command_line(argc, argv, line)) return *exit_code;
  const tracemesh::tbb_under_thread_sanitizer tbb_checkable;  // ThreadSanitizer builds only

  auto log = tracemesh::server::make_json_logger("tracemeshd");
  log->set_level(spdlog::level::from_str(line.log_level));

  // Signals are caught before any thread starts, so every thread inherits the same disposition.
  boost::asio::io_context signal_io;
  boost::asio::signal_set signals(signal_io, SIGINT, SIGTERM);
  int received = 0;
  signals.async_wait([&](const boost::system::error_code&, int signal_number) { received = signal_number; });

  tracemesh::server::service service(line.config, log);
  const tracemesh::status started = service.start();
  if (!started.ok()) {
    // One line a person can read (the JSON log may be going elsewhere), then exit 1.
    std::fprintf(stderr, "tracemeshd: cannot start: %s\n", started.message().c_str());
    return 1;
  }
  signal_io.run();  // blocks until SIGINT or SIGTERM
  tracemesh::server::log_event(*log, spdlog::level::info, "signal", {{"signal", received}});
  service.shutdown();
  return 0;
}
