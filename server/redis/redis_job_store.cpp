#include "server/redis/redis_job_store.hpp"

#include <thread>

#include "server/storage/job_store.hpp"

namespace tracemesh::server {

std::string stored_mesh_key(const std::string& id) { return id + ".mesh"; }

redis_job_store::redis_job_store(redis_job_records& records, redis_run_lease& lease, result_cache& results,
                                 metrics& stats, replica_limits limits)
    : records_(records), lease_(lease), results_(results), stats_(stats), limits_(limits) {}

std::optional<stored_job> redis_job_store::find(const std::string& id) {
  result<std::optional<stored_job>> found = records_.find(id);
  if (!found.ok()) return std::nullopt;
  return std::move(*found);
}

std::shared_ptr<const surface_mesh> redis_job_store::mesh(const std::string& id) {
  const std::shared_ptr<const std::string> bytes = results_.get(stored_mesh_key(id));
  if (!bytes) return nullptr;
  std::optional<surface_mesh> mesh = deserialize_mesh(*bytes);
  if (!mesh) return nullptr;
  return std::make_shared<const surface_mesh>(std::move(*mesh));
}

status redis_job_store::complete(const std::string& id, const stored_job& record_if_new, const surface_mesh& mesh,
                                 std::shared_ptr<const std::string> report) {
  if (const status stored = results_.put(stored_mesh_key(id), serialize_mesh(mesh)); !stored.ok()) {
    return status(errc::io_error, "the shared result store refused the mesh: " + stored.message());
  }
  // The mesh is safe in the shared store: a record Redis cannot take now is written when the job's final state is
  // (the coordinator retries it until Redis is back), so the job is not failed for it.
  result<std::optional<stored_job>> found = records_.find(id);
  if (!found.ok()) return status::success();
  stored_job record = *found ? **found : record_if_new;
  record.id = id;
  record.state = job_state::done;
  record.report = std::move(report);
  record.error_code.clear();
  record.error_message.clear();
  record.finished_ms = unix_millis();
  (void)records_.finish(record);
  return status::success();
}

status redis_job_store::record_encoding(const std::string& id, std::string_view format_name,
                                        const nlohmann::json& entry) {
  return records_.set_encoding(id, format_name, entry.dump());
}

bool redis_job_store::done_elsewhere(const std::string& id) {
  const result<std::optional<stored_job>> found = records_.find(id);
  if (!found.ok() || !*found || (*found)->state != job_state::done) return false;
  // A done record whose mesh the shared store evicted is meshed again.
  if (!results_.get(stored_mesh_key(id))) return false;
  stats_.count_replica_followed();
  return true;
}

result<bool> redis_job_store::claim_run(const std::string& id, progress_token& token) {
  for (;;) {
    const result<bool> acquired = lease_.acquire(id, limits_.reclaim_timeout);
    if (!acquired.ok()) return true;  // Redis is away: mesh without the lease
    if (*acquired) {
      // The lease may be free because its holder just finished the job.
      if (done_elsewhere(id)) {
        (void)lease_.release(id);
        return false;
      }
      std::lock_guard lock(held_mutex_);
      held_.insert(id);
      return true;
    }
    if (done_elsewhere(id)) return false;
    if (token.cancelled()) return status(errc::cancelled, "cancelled while another replica meshed the job");
    std::this_thread::sleep_for(limits_.follow_poll);
  }
}

void redis_job_store::end_run(const std::string& id) {
  {
    std::lock_guard lock(held_mutex_);
    if (held_.erase(id) == 0) return;
  }
  (void)lease_.release(id);  // an unreleased lease expires by itself
}

void redis_job_store::renew_leases() {
  std::set<std::string> held;
  {
    std::lock_guard lock(held_mutex_);
    held = held_;
  }
  for (const std::string& id : held) (void)lease_.renew(id, limits_.reclaim_timeout);
}

}  // namespace tracemesh::server
