#include "server/redis/redis_job_coordinator.hpp"

#include <algorithm>

#include "server/storage/job_store.hpp"
#include "server/observability/logging.hpp"

namespace tracemesh::server {

namespace {

using clock = std::chrono::steady_clock;

/// The stage named `name` (stage_name), reading when none is.
mesh_stage stage_named(const std::string& name) {
  for (int s = 0; s <= static_cast<int>(mesh_stage::done); ++s) {
    if (name == stage_name(static_cast<mesh_stage>(s))) return static_cast<mesh_stage>(s);
  }
  return mesh_stage::reading;
}

/// A running job's live fields (stage, progress, eta) as the record holds them, laid over `job`.
void apply_live_fields(job_snapshot& job, const redis_job_records::live_fields& live) {
  job.stage = stage_named(live.stage);
  job.progress = std::clamp(std::strtod(live.progress.c_str(), nullptr), 0.0, 1.0);
  if (!live.eta_s.empty()) job.eta_seconds = std::strtod(live.eta_s.c_str(), nullptr);
}

}  // namespace

redis_replica::redis_replica(const redis_endpoint& endpoint, const server_config& config, result_cache& results,
                             metrics& stats)
    : name(config.replica_name),
      limits(config.limits),
      client(endpoint, config.limits.redis),
      blocking(endpoint, config.limits.redis),
      records(client, config.limits.job_retention),
      events(endpoint, config.limits.redis, records.events_channel(), config.limits.replicas.max_event_jobs,
             config.limits.replicas.error_pause),
      queue(client, name),
      taker(blocking, name),
      lease(client, name),
      store(records, lease, results, stats, config.limits.replicas) {}

redis_job_coordinator::redis_job_coordinator(redis_replica& replica, job_queue& jobs, unsigned workers,
                                             metrics& stats, spdlog::logger& log)
    : replica_(replica),
      jobs_(jobs),
      workers_(std::max(1u, workers)),
      stats_(stats),
      log_(log),
      limits_(replica.limits.replicas) {}

redis_job_coordinator::~redis_job_coordinator() {
  stop();
  heartbeat_stopping_ = true;
  wake_.notify_all();
  if (heartbeat_.joinable()) heartbeat_.join();
  replica_.events.stop();
  std::vector<pending_final> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(unwritten_);
  }
  for (const pending_final& final_state : left) {
    if (!write_final(final_state)) {
      log_event(log_, spdlog::level::err, "job_final_unwritten",
                {{"job", final_state.id}, {"message", "Redis was away at exit; another replica will run it again"}});
    }
  }
}

status redis_job_coordinator::start() {
  if (const status reachable = replica_.client.connect(); !reachable.ok()) return reachable;
  if (const status group = replica_.queue.ensure_group(); !group.ok()) return group;
  note_redis(true);
  replica_.events.start();
  consumer_ = std::thread([this] { consumer_loop(); });
  heartbeat_ = std::thread([this] { heartbeat_loop(); });
  return status::success();
}

void redis_job_coordinator::stop() {
  consumer_stopping_ = true;
  wake_.notify_all();
  if (consumer_.joinable()) consumer_.join();
}

bool redis_job_coordinator::pause(std::atomic<bool>& stopping, std::chrono::milliseconds time) {
  std::unique_lock lock(wake_mutex_);
  wake_.wait_for(lock, time, [&] { return stopping.load(); });
  return !stopping.load();
}

void redis_job_coordinator::note_redis(bool up) {
  const bool was = redis_up_.exchange(up);
  if (was == up) return;
  log_event(log_, up ? spdlog::level::info : spdlog::level::err, up ? "redis_up" : "redis_down",
            {{"redis", replica_.client.endpoint().to_url()}, {"replica", replica_.name}});
}

std::optional<std::string> redis_job_coordinator::unready_reason() const {
  if (redis_up()) return std::nullopt;
  return "Redis at " + replica_.client.endpoint().to_url() + " is unreachable";
}

// ---- accepting and looking up -------------------------------------------------------------------------------

accept_result redis_job_coordinator::accept(const std::string& id, std::shared_ptr<const job_input> input,
                                            const std::string& owner_hash) {
  const stored_job record = accepted_record(id, *input, owner_hash);
  const result<redis_job_records::accept_outcome> accepted = replica_.records.accept_and_queue(
      record, serialize_molecule(input->mol), replica_.queue.stream_key(), redis_work_queue::group,
      replica_.limits.max_queue);
  if (!accepted.ok()) {
    note_redis(false);
    return {submit_outcome::shutting_down, {}, accepted.error()};
  }
  job_snapshot snapshot = snapshot_from_record(record);
  switch (*accepted) {
    case redis_job_records::accept_outcome::queue_full: return {submit_outcome::queue_full, {}, status::success()};
    case redis_job_records::accept_outcome::coalesced:
      if (result<std::optional<job_snapshot>> now = find(id); now.ok() && *now) snapshot = **now;
      return {submit_outcome::coalesced, std::move(snapshot), status::success()};
    case redis_job_records::accept_outcome::accepted: break;
  }
  wake_.notify_all();  // an idle consumer of this replica may take it at once
  return {submit_outcome::accepted, std::move(snapshot), status::success()};
}

result<std::optional<job_snapshot>> redis_job_coordinator::find(const std::string& id) {
  const result<std::optional<stored_job>> found = replica_.records.find(id);
  if (!found.ok()) return found.error();
  std::optional<job_snapshot> local = jobs_.find(id);
  if (!*found) return local;  // a synchronous job of this replica not recorded yet, or unknown
  // This replica runs it: the freshest view, and the one its /jobs/{id}/mesh route goes by (the record says done a
  // moment before the local job is).
  if (local && !proto::is_final(local->state)) return local;
  job_snapshot job = snapshot_from_record(**found);
  if (job.state != job_state::running) return std::optional(std::move(job));
  const auto live = replica_.records.find_progress(id);
  if (live.ok() && *live) apply_live_fields(job, **live);
  return std::optional(std::move(job));
}

withdraw_result redis_job_coordinator::withdraw(const std::string& id, const std::string& owner_hash) {
  using outcome = redis_job_records::withdraw_outcome;
  const result<outcome> withdrawn = replica_.records.withdraw(id, owner_hash);
  if (!withdrawn.ok()) return {cancel_outcome::not_found, std::nullopt, withdrawn.error()};
  cancel_outcome result_outcome = cancel_outcome::not_found;
  switch (*withdrawn) {
    case outcome::not_found: return {cancel_outcome::not_found, std::nullopt, status::success()};
    case outcome::not_owner: return {cancel_outcome::not_owner, std::nullopt, status::success()};
    case outcome::already_final: result_outcome = cancel_outcome::already_final; break;
    case outcome::withdrawn: result_outcome = cancel_outcome::withdrawn; break;
    case outcome::cancelled: result_outcome = cancel_outcome::cancelled; break;
    case outcome::cancelling:
      jobs_.cancel(id);  // when it runs here; else its replica sees the record's cancel field at its heartbeat
      result_outcome = cancel_outcome::cancelled;
      break;
  }
  result<std::optional<job_snapshot>> job = find(id);
  return {result_outcome, job.ok() ? std::move(*job) : std::nullopt, status::success()};
}

// ---- the consumer -------------------------------------------------------------------------------------------

bool redis_job_coordinator::has_free_worker() const {
  return jobs_.queue_depth() == 0 && jobs_.running_jobs() < workers_;
}

void redis_job_coordinator::consumer_loop() {
  auto next_reclaim = clock::now();
  while (!consumer_stopping_) {
    if (!has_free_worker()) {
      pause(consumer_stopping_, limits_.idle_poll);
      continue;
    }
    bool reclaimed = false;
    const result<std::vector<queue_entry>> entries = next_entries(next_reclaim, reclaimed);
    if (!entries.ok()) {
      note_redis(false);
      pause(consumer_stopping_, limits_.error_pause);
      (void)replica_.queue.ensure_group();  // a Redis that came back empty (no append-only file) has no group
      continue;
    }
    note_redis(true);
    for (const queue_entry& entry : *entries) start_entry(entry, reclaimed);
  }
}

result<std::vector<queue_entry>> redis_job_coordinator::next_entries(clock::time_point& next_reclaim,
                                                                    bool& reclaimed) {
  if (clock::now() >= next_reclaim) {
    next_reclaim = clock::now() + std::max(limits_.reclaim_timeout / 4, std::chrono::milliseconds(1));
    result<std::vector<queue_entry>> taken_over = replica_.queue.reclaim(limits_.reclaim_timeout, 1);
    if (!taken_over.ok()) return taken_over.error();
    if (!taken_over->empty()) {
      reclaimed = true;
      return taken_over;
    }
  }
  return replica_.taker.take(1, limits_.take_block);
}

std::shared_ptr<const job_input> redis_job_coordinator::load_input(const stored_job& record) {
  const result<std::optional<std::string>> bytes = replica_.records.input(record.id);
  if (!bytes.ok() || !*bytes) return nullptr;
  std::optional<molecule> mol = deserialize_molecule(**bytes);
  result<mesh_params> params = parse_canonical_parameters(record.parameters);
  if (!mol || !params.ok()) return nullptr;
  auto input = std::make_shared<job_input>();
  input->mol = std::move(*mol);
  input->params = *params;
  input->format = record.format;
  return input;
}

void redis_job_coordinator::start_entry(const queue_entry& entry, bool reclaimed) {
  const result<std::optional<stored_job>> found = replica_.records.find(entry.job_id);
  if (!found.ok()) return;  // stays pending: reclaimed once Redis answers again
  if (!*found || proto::is_final((*found)->state)) {  // withdrawn while queued, or done by a duplicate entry
    (void)replica_.queue.ack(entry.entry_id);
    return;
  }
  const stored_job& record = **found;
  std::shared_ptr<const job_input> input = load_input(record);
  if (!input) {
    const pending_final lost{record.id, entry.entry_id, job_state::failed, lost_job_error,
                             "the job's input could not be read from Redis; submit it again", nullptr};
    if (!write_final(lost)) return;
    log_event(log_, spdlog::level::err, "job_lost", {{"job", record.id}, {"replica", replica_.name}});
    return;
  }
  (void)replica_.records.mark_running(record.id, replica_.name);
  {
    std::lock_guard lock(mutex_);
    in_flight_[record.id] = entry.entry_id;
  }
  stats_.count_replica_job(reclaimed);
  log_event(log_, spdlog::level::info, reclaimed ? "job_reclaimed" : "job_taken",
            {{"job", record.id}, {"entry", entry.entry_id}, {"replica", replica_.name}});
  const submit_result submitted = jobs_.submit(
      record.id, std::move(input),
      [this, entry_id = entry.entry_id](const job_snapshot& final_state, const job_output* output) {
        on_final(entry_id, final_state, output);
      },
      submit_options{std::nullopt, true});
  if (submitted.outcome == submit_outcome::shutting_down) {  // left pending for another replica
    std::lock_guard lock(mutex_);
    in_flight_.erase(record.id);
  }
}

void redis_job_coordinator::on_final(const std::string& entry_id, const job_snapshot& final_state,
                                     const job_output* output) {
  {
    std::lock_guard lock(mutex_);
    in_flight_.erase(final_state.id);
  }
  // Stopped by this replica's shutdown: the entry stays pending and another replica reclaims the job.
  if (final_state.error_code == job_error::shutdown) return;
  pending_final final_record{final_state.id,
                             entry_id,
                             final_state.state,
                             final_state.error_code,
                             final_state.error.ok() ? std::string() : final_state.error.message(),
                             output ? output->report : nullptr};
  if (write_final(final_record)) return;
  std::lock_guard lock(mutex_);
  unwritten_.push_back(std::move(final_record));
}

bool redis_job_coordinator::write_final(const pending_final& final_state) {
  const result<std::optional<stored_job>> found = replica_.records.find(final_state.id);
  if (!found.ok()) return false;
  stored_job record;
  if (*found) record = **found;
  record.id = final_state.id;
  if (record.state != job_state::done) {  // a done result stays done (complete() wrote it with its mesh)
    record.state = final_state.state;
    record.error_code = final_state.error_code;
    record.error_message = final_state.error_message;
    if (final_state.report) record.report = final_state.report;
    record.finished_ms = unix_millis();
    if (!replica_.records.finish(record).ok()) return false;
  }
  return replica_.queue.ack(final_state.entry_id).ok();
}

// ---- the heartbeat ------------------------------------------------------------------------------------------

void redis_job_coordinator::heartbeat_loop() {
  while (pause(heartbeat_stopping_, limits_.heartbeat)) heartbeat_once();
}

void redis_job_coordinator::heartbeat_once() {
  const result<redis_reply> pong = replica_.client.command({"PING"});
  note_redis(pong.ok() && pong->is_status("PONG"));
  if (!redis_up()) return;
  std::map<std::string, std::string> in_flight;
  std::vector<pending_final> unwritten;
  {
    std::lock_guard lock(mutex_);
    in_flight = in_flight_;
    unwritten.swap(unwritten_);
  }
  for (const auto& [id, entry_id] : in_flight) {
    (void)replica_.queue.touch(entry_id);
    if (const result<bool> cancel = replica_.records.cancel_requested(id); cancel.ok() && *cancel) jobs_.cancel(id);
    const std::optional<job_snapshot> job = jobs_.find(id);
    if (job && job->state == job_state::running) {
      (void)replica_.records.set_progress(id, stage_name(job->stage), job->progress, job->eta_seconds);
    }
  }
  replica_.store.renew_leases();
  std::vector<pending_final> still;
  for (pending_final& final_state : unwritten) {
    if (!write_final(final_state)) still.push_back(std::move(final_state));
  }
  if (still.empty()) return;
  std::lock_guard lock(mutex_);
  unwritten_.insert(unwritten_.end(), std::make_move_iterator(still.begin()), std::make_move_iterator(still.end()));
}

}  // namespace tracemesh::server
