#include "server/admission/server_limits.hpp"

#include <charconv>

namespace tracemesh::server {

bool parse_listen_address(const std::string& text, server_config& config) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) return false;
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  unsigned port = 0;
  const char* first = text.data() + colon + 1;
  const char* last = text.data() + text.size();
  const auto [end, error] = std::from_chars(first, last, port);
  if (error != std::errc{} || end != last || port > 65535) return false;
  config.listen_host = host;
  config.listen_port = static_cast<unsigned short>(port);
  return true;
}

namespace {

double seconds(std::chrono::milliseconds duration) { return static_cast<double>(duration.count()) / 1000.0; }

std::vector<std::string> trusted_proxy_texts(const std::vector<ip_network>& networks) {
  std::vector<std::string> texts;
  for (const ip_network& network : networks) texts.push_back(network.to_string());
  return texts;
}

}  // namespace

nlohmann::json config_to_json(const server_config& config) {
  const server_limits& limits = config.limits;
  return {
      {"listen", config.listen_host + ":" + std::to_string(config.listen_port)},
      {"workers", config.workers},
      {"mesher_threads", config.mesher_threads},
      {"io_threads", config.io_threads},
      {"prep_threads", config.prep_threads},
      {"large_upload_threads", config.large_upload_threads},
      {"small_job_workers", config.small_job_workers},
      {"cache_dir", config.cache_dir.string()},
      {"job_dir", config.job_dir.string()},
      {"durable_jobs", !config.job_dir.empty() || !config.store_url.empty()},
      {"store", config.store_url.empty() ? std::string("local") : config.store_url},
      {"replica", config.replica_name},
      {"auth", !config.auth_token_file.empty()},
      {"auth_exempt_routes", config.auth_exempt_routes},
      {"job_retention_s", seconds(limits.job_retention)},
      {"job_store_memory_bytes", limits.job_store_memory_bytes},
      {"cors_origins", config.cors_origins},
      {"max_atoms", limits.mesh.max_atoms},
      {"max_triangles", limits.mesh.max_triangles},
      {"max_lattice_points", limits.mesh.max_lattice_points},
      {"max_upload_bytes", limits.max_upload_bytes},
      {"max_pqr_bytes", limits.max_pqr_bytes},
      {"max_small_body_bytes", limits.max_small_body_bytes},
      {"max_header_bytes", limits.max_header_bytes},
      {"max_connections", limits.max_connections},
      {"health_connection_reserve", limits.health_connection_reserve},
      {"probe_header_timeout_ms", limits.probe_header_timeout.count()},
      {"accept_error_pause_ms", limits.accept_error_pause.count()},
      {"max_event_streams", limits.max_event_streams},
      {"max_event_streams_per_client", limits.max_event_streams_per_client},
      {"refusal_log_interval_s", seconds(limits.refusal_log_interval)},
      {"max_refusal_log_clients", limits.max_refusal_log_clients},
      {"event_interval_ms", limits.event_interval.count()},
      {"event_keepalive_s", seconds(limits.event_keepalive)},
      {"max_concurrent_uploads", limits.max_concurrent_uploads},
      {"max_upload_bytes_in_flight", limits.max_upload_bytes_in_flight},
      {"min_upload_bytes_per_second", limits.min_upload_bytes_per_second},
      {"upload_rate_grace_s", seconds(limits.upload_rate_grace)},
      {"large_upload_bytes", limits.large_upload_bytes},
      {"max_connections_per_client", limits.max_connections_per_client},
      {"max_uploads_per_client", limits.max_uploads_per_client},
      {"max_jobs_per_client", limits.max_jobs_per_client},
      {"trusted_proxies", trusted_proxy_texts(limits.trusted_proxies)},
      {"small_job_max_atoms", limits.small_job_max_atoms},
      {"max_form_parts", limits.max_form_parts},
      {"max_form_field_bytes", limits.max_form_field_bytes},
      {"max_queue", limits.max_queue},
      {"max_job_records", limits.max_job_records},
      {"job_timeout_s", seconds(limits.job_timeout)},
      {"header_timeout_s", seconds(limits.header_timeout)},
      {"request_timeout_s", seconds(limits.request_timeout)},
      {"write_timeout_s", seconds(limits.write_timeout)},
      {"linger_time_s", seconds(limits.linger_time)},
      {"shutdown_grace_s", seconds(limits.shutdown_grace)},
      {"retry_after_s", limits.retry_after_seconds},
      {"cache_memory_bytes", limits.cache_memory_bytes},
      {"cache_disk_bytes", limits.cache_disk_bytes},
      {"redis_connect_timeout_ms", limits.redis.connect_timeout.count()},
      {"redis_command_timeout_ms", limits.redis.command_timeout.count()},
      {"redis_reconnect_backoff_initial_ms", limits.redis.reconnect_backoff_initial.count()},
      {"redis_reconnect_backoff_max_ms", limits.redis.reconnect_backoff_max.count()},
      {"reclaim_timeout_ms", limits.replicas.reclaim_timeout.count()},
      {"replica_heartbeat_ms", limits.replicas.heartbeat.count()},
      {"replica_take_block_ms", limits.replicas.take_block.count()},
      {"replica_follow_poll_ms", limits.replicas.follow_poll.count()},
      {"replica_idle_poll_ms", limits.replicas.idle_poll.count()},
      {"replica_error_pause_ms", limits.replicas.error_pause.count()},
      {"replica_event_fallback_ms", limits.replicas.event_fallback.count()},
      {"replica_max_event_jobs", limits.replicas.max_event_jobs},
  };
}

}  // namespace tracemesh::server
