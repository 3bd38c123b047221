#include "server/observability/metrics.hpp"

#include <charconv>

namespace tracemesh::server {

namespace {

void family(std::string& out, const char* name, const char* type, const char* help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}

// Shortest text that reads back as `value` ("0.01", "2.5", "300"), so bucket labels are what people expect.
std::string number(double value) {
  char text[64];
  const auto written = std::to_chars(text, text + sizeof text, value);
  return std::string(text, written.ptr);
}

void sample(std::string& out, const std::string& name_and_labels, double value) {
  out += name_and_labels;
  out += ' ';
  out += number(value);
  out += '\n';
}

void sample(std::string& out, const std::string& name_and_labels, std::uint64_t value) {
  out += name_and_labels;
  out += ' ';
  out += std::to_string(value);
  out += '\n';
}

// Label values are route templates and state names chosen by the server; escape anyway per the format.
std::string label_value(std::string_view value) {
  std::string escaped;
  for (char c : value) {
    if (c == '\\' || c == '"') escaped += '\\';
    if (c == '\n') {
      escaped += "\\n";
      continue;
    }
    escaped += c;
  }
  return escaped;
}

}  // namespace

void metrics::count_request(std::string_view route, unsigned status) {
  std::lock_guard lock(mutex_);
  auto it = requests_.find(std::make_pair(std::string(route), status));
  if (it == requests_.end()) {
    requests_.emplace(std::make_pair(std::string(route), status), 1);
  } else {
    ++it->second;
  }
}

std::uint64_t metrics::requests(std::string_view route, unsigned status) const {
  std::lock_guard lock(mutex_);
  const auto it = requests_.find(std::make_pair(std::string(route), status));
  return it == requests_.end() ? 0 : it->second;
}

void metrics::count_job_finished(std::string_view state, double seconds) {
  std::lock_guard lock(mutex_);
  auto it = jobs_finished_.find(state);
  if (it == jobs_finished_.end()) {
    jobs_finished_.emplace(std::string(state), 1);
  } else {
    ++it->second;
  }
  for (std::size_t i = 0; i < job_seconds_buckets.size(); ++i) {
    if (seconds <= job_seconds_buckets[i]) {
      ++job_seconds_counts_[i];
      break;
    }
  }
  ++job_seconds_count_;
  job_seconds_sum_ += seconds;
}

std::string metrics::render(const metrics_gauges& gauges) const {
  std::string out;
  std::lock_guard lock(mutex_);

  family(out, "tracemesh_http_requests_total", "counter", "HTTP requests answered, by route and status.");
  for (const auto& [key, count] : requests_) {
    sample(out,
           "tracemesh_http_requests_total{route=\"" + label_value(key.first) + "\",status=\"" +
               std::to_string(key.second) + "\"}",
           count);
  }

  family(out, "tracemesh_mesher_runs_total", "counter", "Real runs of the mesher (coalesced and cached jobs excluded).");
  sample(out, "tracemesh_mesher_runs_total", mesher_runs_.load(std::memory_order_relaxed));

  family(out, "tracemesh_trace_fallbacks_total", "counter",
         "Trace jobs the trace path failed and the lattice path meshed instead (their reports say why).");
  sample(out, "tracemesh_trace_fallbacks_total", trace_fallbacks_.load(std::memory_order_relaxed));

  family(out, "tracemesh_trace_grid_retries_total", "counter",
         "Trace attempts that failed inside the engine and were made again on another line grid.");
  sample(out, "tracemesh_trace_grid_retries_total", trace_grid_retries_.load(std::memory_order_relaxed));

  family(out, "tracemesh_jobs_finished_total", "counter", "Jobs that reached a final state, by state.");
  for (const auto& [state, count] : jobs_finished_) {
    sample(out, "tracemesh_jobs_finished_total{state=\"" + label_value(state) + "\"}", count);
  }

  family(out, "tracemesh_job_seconds", "histogram", "Wall time of finished jobs, seconds.");
  std::uint64_t cumulative = 0;
  for (std::size_t i = 0; i < job_seconds_buckets.size(); ++i) {
    cumulative += job_seconds_counts_[i];
    sample(out, "tracemesh_job_seconds_bucket{le=\"" + number(job_seconds_buckets[i]) + "\"}", cumulative);
  }
  sample(out, "tracemesh_job_seconds_bucket{le=\"+Inf\"}", job_seconds_count_);
  sample(out, "tracemesh_job_seconds_sum", job_seconds_sum_);
  sample(out, "tracemesh_job_seconds_count", job_seconds_count_);

  family(out, "tracemesh_queue_depth", "gauge", "Jobs waiting for a worker.");
  sample(out, "tracemesh_queue_depth", static_cast<std::uint64_t>(gauges.queue_depth));
  family(out, "tracemesh_running_jobs", "gauge", "Jobs being meshed.");
  sample(out, "tracemesh_running_jobs", static_cast<std::uint64_t>(gauges.running_jobs));
  family(out, "tracemesh_open_connections", "gauge", "Open HTTP connections.");
  sample(out, "tracemesh_open_connections", static_cast<std::uint64_t>(gauges.open_connections));

  family(out, "tracemesh_cache_responses_total", "counter", "Responses served from the cache without a job.");
  sample(out, "tracemesh_cache_responses_total", cache_responses_.load(std::memory_order_relaxed));
  family(out, "tracemesh_mesh_compressions_total", "counter",
         "Mesh encodings compressed for a response (once per job, format and coding; then cached), by coding.");
  sample(out, "tracemesh_mesh_compressions_total{coding=\"gzip\"}", gzip_compressions_.load(std::memory_order_relaxed));
  sample(out, "tracemesh_mesh_compressions_total{coding=\"br\"}", br_compressions_.load(std::memory_order_relaxed));
  family(out, "tracemesh_cache_hits_total", "counter", "Result cache lookups that found an entry.");
  sample(out, "tracemesh_cache_hits_total", gauges.cache_hits);
  family(out, "tracemesh_cache_misses_total", "counter", "Result cache lookups that found nothing.");
  sample(out, "tracemesh_cache_misses_total", gauges.cache_misses);
  family(out, "tracemesh_cache_corrupt_entries_total", "counter", "Cache entries found corrupt and removed.");
  sample(out, "tracemesh_cache_corrupt_entries_total", gauges.cache_corrupt_entries);
  family(out, "tracemesh_cache_evictions_total", "counter", "Cache entries evicted to stay within the limits.");
  sample(out, "tracemesh_cache_evictions_total", gauges.cache_evictions);
  family(out, "tracemesh_cache_write_failures_total", "counter", "Cache writes that failed (entry not stored).");
  sample(out, "tracemesh_cache_write_failures_total", gauges.cache_write_failures);
  family(out, "tracemesh_cache_memory_bytes", "gauge", "Bytes held by the in-memory cache.");
  sample(out, "tracemesh_cache_memory_bytes", gauges.cache_memory_bytes);
  family(out, "tracemesh_cache_disk_bytes", "gauge", "Bytes held by the on-disk cache.");
  sample(out, "tracemesh_cache_disk_bytes", gauges.cache_disk_bytes);
  family(out, "tracemesh_cache_entries", "gauge", "Entries in the cache.");
  sample(out, "tracemesh_cache_entries", gauges.cache_entries);
  if (!gauges.replica.empty()) render_replica(out, gauges);
  return out;
}

void metrics::render_replica(std::string& out, const metrics_gauges& gauges) const {
  const std::string replica = "replica=\"" + label_value(gauges.replica) + "\"";
  family(out, "tracemesh_replica_info", "gauge", "This replica of a Redis-coordinated group (--store), by name.");
  sample(out, "tracemesh_replica_info{" + replica + "}", std::uint64_t{1});
  family(out, "tracemesh_redis_up", "gauge", "1 while Redis answered this replica's last heartbeat.");
  sample(out, "tracemesh_redis_up{" + replica + "}", std::uint64_t{gauges.redis_up ? 1u : 0u});
  family(out, "tracemesh_replica_jobs_total", "counter",
         "Jobs this replica ran from the shared stream (taken new, or reclaimed from a dead replica) and jobs it "
         "found meshed by another replica while it waited on the run lease (followed).");
  sample(out, "tracemesh_replica_jobs_total{" + replica + ",how=\"taken\"}",
         replica_taken_.load(std::memory_order_relaxed));
  sample(out, "tracemesh_replica_jobs_total{" + replica + ",how=\"reclaimed\"}",
         replica_reclaimed_.load(std::memory_order_relaxed));
  sample(out, "tracemesh_replica_jobs_total{" + replica + ",how=\"followed\"}",
         replica_followed_.load(std::memory_order_relaxed));
}

}  // namespace tracemesh::server
