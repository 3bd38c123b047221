#include "server/jobs/job_queue.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <new>

#include "core/stage_weights.hpp"

namespace tracemesh::server {

namespace {

using clock = std::chrono::steady_clock;

double seconds_between(clock::time_point from, clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

}  // namespace

struct job_queue::job {
  job(std::string job_id, std::shared_ptr<const job_input> job_in)
      : id(std::move(job_id)),
        input(std::move(job_in)),
        token([this](mesh_stage s, double f) {
          // done is the queue's to set (finish()): the mesher reports it before the job encodes its outputs.
          if (s == mesh_stage::done) return;
          stage.store(static_cast<int>(s), std::memory_order_relaxed);
          // Proportional to expected time (stage weights of the job's path). A job skips the stages its path does
          // not run; progress then jumps over their (zero or small) shares. Never backwards, whatever order the work
          // reports in (the token serialises these calls).
          const mesh_params& params = input->params;
          const double overall = overall_progress(params.method, params.refine, s, f);
          if (overall > progress.load(std::memory_order_relaxed)) progress.store(overall, std::memory_order_relaxed);
          eta.observe(progress.load(std::memory_order_relaxed), clock::now());
        }) {}

  const std::string id;
  const std::shared_ptr<const job_input> input;
  // Written by the pipeline through the token, read by snapshots: atomics, no lock.
  std::atomic<int> stage{0};
  std::atomic<double> progress{0};
  eta_estimator eta;
  progress_token token;
  // Guarded by job_queue::mutex_.
  job_state state = job_state::queued;
  stop_reason stop = stop_reason::none;
  clock::time_point started{};
  clock::time_point deadline{};
  double seconds = 0;
  std::string error_code;
  status error;
  std::shared_ptr<const std::string> report;
  std::vector<job_listener> listeners;
  std::vector<std::string> owners;  // owner token hashes still holding the job
  std::size_t anonymous_holders = 0;

  void hold(const std::optional<job_holder>& holder) {
    if (!holder) return;
    if (holder->owner_hash.empty()) {
      ++anonymous_holders;
    } else {
      owners.push_back(holder->owner_hash);
    }
  }
};

job_queue::job_queue(job_queue_options options, job_work work, metrics& stats, job_listener on_final)
    : options_(options), work_(std::move(work)), metrics_(stats), on_final_(std::move(on_final)) {
  const unsigned workers = std::max(1u, options_.workers);
  workers_.reserve(workers + options_.small_job_workers);
  for (unsigned i = 0; i < workers; ++i) workers_.emplace_back([this] { worker_loop(false); });
  for (unsigned i = 0; i < options_.small_job_workers; ++i) workers_.emplace_back([this] { worker_loop(true); });
  watchdog_ = std::thread([this] { watchdog_loop(); });
}

job_queue::~job_queue() { shutdown(std::chrono::milliseconds(0)); }

submit_result job_queue::submit(const std::string& id, std::shared_ptr<const job_input> input,
                                job_listener listener, submit_options how) {
  std::unique_lock lock(mutex_);
  if (!accepting_) return {submit_outcome::shutting_down, {}};
  const auto existing = jobs_.find(id);
  if (existing != jobs_.end() && !proto::is_final(existing->second->state)) {
    if (listener) existing->second->listeners.push_back(std::move(listener));
    existing->second->hold(how.holder);
    return {submit_outcome::coalesced, snapshot_of(*existing->second)};
  }
  if (queue_.size() >= options_.max_queue && !how.recovered) return {submit_outcome::queue_full, {}};
  auto created = std::make_shared<job>(id, std::move(input));
  if (listener) created->listeners.push_back(std::move(listener));
  created->hold(how.holder);
  jobs_[id] = created;
  queue_.push_back(created);
  job_snapshot snapshot = snapshot_of(*created);
  lock.unlock();
  // All: a small-lane worker woken for a big job would go back to sleep while a general worker stays idle.
  work_available_.notify_all();
  return {submit_outcome::accepted, std::move(snapshot)};
}

bool job_queue::subscribe(const std::string& id, job_listener listener) {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end() || proto::is_final(it->second->state)) return false;
  it->second->listeners.push_back(std::move(listener));
  return true;
}

std::optional<job_snapshot> job_queue::find(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return snapshot_of(*it->second);
}

std::size_t job_queue::listeners(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  return it == jobs_.end() ? 0 : it->second->listeners.size();
}

cancel_outcome job_queue::cancel(const std::string& id) {
  std::unique_lock lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return cancel_outcome::not_found;
  return cancel_locked(lock, it->second);
}

cancel_outcome job_queue::withdraw(const std::string& id, const std::string& owner_hash) {
  std::unique_lock lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return cancel_outcome::not_found;
  const std::shared_ptr<job> target = it->second;
  if (proto::is_final(target->state)) return cancel_outcome::already_final;
  const auto owner = std::find(target->owners.begin(), target->owners.end(), owner_hash);
  if (owner == target->owners.end()) return cancel_outcome::not_owner;
  target->owners.erase(owner);
  if (!target->owners.empty() || target->anonymous_holders > 0) return cancel_outcome::withdrawn;
  return cancel_locked(lock, target);
}

cancel_outcome job_queue::cancel_locked(std::unique_lock<std::mutex>& lock, const std::shared_ptr<job>& target) {
  if (proto::is_final(target->state)) return cancel_outcome::already_final;
  if (target->state == job_state::running) {
    // The worker sees the token, the work returns errc::cancelled and finish() records "cancelled".
    if (target->stop == stop_reason::none) target->stop = stop_reason::user;
    target->token.cancel();
    return cancel_outcome::cancelled;
  }
  queue_.erase(std::find(queue_.begin(), queue_.end(), target));
  target->state = job_state::cancelled;
  target->error_code = job_error::cancelled;
  target->error = status(errc::cancelled, "cancelled by request");
  remember_finished(target);
  std::vector<job_listener> listeners = std::move(target->listeners);
  const job_snapshot final_state = snapshot_of(*target);
  metrics_.count_job_finished(proto::job_state_name(job_state::cancelled), 0.0);  // as in finish(): while locked
  lock.unlock();
  idle_or_stopping_.notify_all();
  notify(std::move(listeners), final_state, nullptr);
  return cancel_outcome::cancelled;
}

void job_queue::shutdown(std::chrono::milliseconds grace) {
  std::lock_guard serial(shutdown_mutex_);
  std::unique_lock lock(mutex_);
  if (joined_) return;
  accepting_ = false;
  idle_or_stopping_.wait_for(lock, grace, [this] { return queue_.empty() && running_.empty(); });

  // Grace is over: queued jobs fail at once, running jobs are asked to stop.
  std::vector<std::pair<std::vector<job_listener>, job_snapshot>> dropped;
  for (const auto& waiting : queue_) {
    waiting->state = job_state::failed;
    waiting->error_code = job_error::shutdown;
    waiting->error = status(errc::cancelled, "the server shut down before the job started");
    remember_finished(waiting);
    metrics_.count_job_finished(proto::job_state_name(job_state::failed), 0.0);  // as in finish(): while locked
    dropped.emplace_back(std::move(waiting->listeners), snapshot_of(*waiting));
  }
  queue_.clear();
  for (const auto& active : running_) {
    if (active->stop == stop_reason::none) active->stop = stop_reason::shutdown;
    active->token.cancel();
  }
  stopping_ = true;
  lock.unlock();
  work_available_.notify_all();
  idle_or_stopping_.notify_all();
  for (auto& [listeners, final_state] : dropped) notify(std::move(listeners), final_state, nullptr);
  for (auto& worker : workers_) worker.join();
  watchdog_.join();
  lock.lock();
  joined_ = true;
}

bool job_queue::accepting() const {
  std::lock_guard lock(mutex_);
  return accepting_;
}

std::size_t job_queue::queue_depth() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

std::size_t job_queue::running_jobs() const {
  std::lock_guard lock(mutex_);
  return running_.size();
}

std::deque<std::shared_ptr<job_queue::job>>::iterator job_queue::next_for(bool small_lane) {
  if (!small_lane) return queue_.begin();
  return std::find_if(queue_.begin(), queue_.end(), [this](const std::shared_ptr<job>& queued) {
    const std::size_t atoms = queued->input ? queued->input->mol.atoms.size() : 0;
    return atoms <= options_.small_job_max_atoms;
  });
}

void job_queue::worker_loop(bool small_lane) {
  for (;;) {
    std::shared_ptr<job> next;
    {
      std::unique_lock lock(mutex_);
      work_available_.wait(lock, [&] { return stopping_ || next_for(small_lane) != queue_.end(); });
      const auto chosen = next_for(small_lane);
      if (chosen == queue_.end()) return;  // stopping and nothing left for this worker
      next = *chosen;
      queue_.erase(chosen);
      next->state = job_state::running;
      next->started = clock::now();
      next->eta.start(next->started);
      next->deadline = next->started + options_.job_timeout;
      running_.push_back(next);
    }
    run(next);
  }
}

void job_queue::run(const std::shared_ptr<job>& j) {
  auto outcome = [&]() -> result<job_output> {
    try {
      return work_(j->id, *j->input, j->token);
    } catch (const std::bad_alloc&) {
      return status(errc::internal_error, "out of memory while running the job");
    } catch (const std::exception& error) {
      return status(errc::internal_error, std::string("the job failed unexpectedly: ") + error.what());
    } catch (...) {
      return status(errc::internal_error, "the job failed unexpectedly");
    }
  }();
  finish(j, std::move(outcome));
}

void job_queue::finish(const std::shared_ptr<job>& j, result<job_output> outcome) {
  std::unique_lock lock(mutex_);
  running_.erase(std::find(running_.begin(), running_.end(), j));
  j->seconds = seconds_between(j->started, clock::now());
  if (outcome.ok()) {
    j->state = job_state::done;
    j->stage.store(static_cast<int>(mesh_stage::done), std::memory_order_relaxed);
    j->report = outcome->report;
  } else if (outcome.error().code() == errc::cancelled && j->stop == stop_reason::user) {
    j->state = job_state::cancelled;
    j->error_code = job_error::cancelled;
    j->error = status(errc::cancelled, "cancelled by request");
  } else if (outcome.error().code() == errc::cancelled && j->stop == stop_reason::timeout) {
    j->state = job_state::failed;
    j->error_code = job_error::timeout;
    j->error = status(errc::cancelled, "the job exceeded its time limit of " +
                                           std::to_string(options_.job_timeout.count()) + " ms");
  } else if (outcome.error().code() == errc::cancelled && j->stop == stop_reason::shutdown) {
    j->state = job_state::failed;
    j->error_code = job_error::shutdown;
    j->error = status(errc::cancelled, "the server shut down while the job was running");
  } else {
    j->state = job_state::failed;
    j->error_code = errc_name(outcome.error().code());
    j->error = outcome.error();
  }
  remember_finished(j);
  std::vector<job_listener> listeners = std::move(j->listeners);
  const job_snapshot final_state = snapshot_of(*j);
  // Counted before the final state can be read (find() takes this lock): whoever sees the job final finds it in
  // /metrics too. The metrics lock is a leaf (render() samples its gauges before taking it).
  metrics_.count_job_finished(proto::job_state_name(final_state.state), final_state.seconds);
  lock.unlock();
  idle_or_stopping_.notify_all();
  notify(std::move(listeners), final_state, outcome.ok() ? &outcome.value() : nullptr);
}

void job_queue::watchdog_loop() {
  // Checks deadlines a few times per timeout period; a job overruns its deadline by at most one tick.
  const auto tick = std::clamp<std::chrono::milliseconds>(options_.job_timeout / 20, std::chrono::milliseconds(5),
                                                          std::chrono::milliseconds(100));
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    const auto now = clock::now();
    for (const auto& active : running_) {
      if (active->stop == stop_reason::none && now >= active->deadline) {
        active->stop = stop_reason::timeout;
        active->token.cancel();
      }
    }
    idle_or_stopping_.wait_for(lock, tick);
  }
}

void job_queue::remember_finished(const std::shared_ptr<job>& j) {
  finished_.push_back(j);
  while (finished_.size() > options_.max_records) {
    const std::shared_ptr<job> oldest = finished_.front();
    finished_.pop_front();
    const auto it = jobs_.find(oldest->id);
    // The id may have been resubmitted since: only forget the record if it is still this finished job.
    if (it != jobs_.end() && it->second == oldest) jobs_.erase(it);
  }
}

job_snapshot job_queue::snapshot_of(const job& j) const {
  job_snapshot snapshot;
  snapshot.id = j.id;
  snapshot.state = j.state;
  snapshot.format = j.input ? j.input->format : proto::mesh_format::off;
  snapshot.stage = static_cast<mesh_stage>(j.stage.load(std::memory_order_relaxed));
  snapshot.progress = j.state == job_state::done ? 1.0 : j.progress.load(std::memory_order_relaxed);
  if (j.state == job_state::queued) {
    const auto position = std::find_if(queue_.begin(), queue_.end(), [&](const auto& q) { return q.get() == &j; });
    snapshot.queue_position = static_cast<std::size_t>(position - queue_.begin());
    snapshot.progress = 0;
  }
  snapshot.error_code = j.error_code;
  snapshot.error = j.error;
  snapshot.report = j.report;
  const auto now = clock::now();
  snapshot.seconds = j.state == job_state::running ? seconds_between(j.started, now) : j.seconds;
  if (j.state == job_state::running) snapshot.eta_seconds = j.eta.remaining_seconds(now);
  if (j.state == job_state::done) snapshot.eta_seconds = 0.0;
  return snapshot;
}

void job_queue::notify(std::vector<job_listener> listeners, const job_snapshot& final_state,
                       const job_output* output) const {
  if (on_final_) listeners.insert(listeners.begin(), on_final_);
  for (auto& listener : listeners) {
    try {
      listener(final_state, output);
    } catch (...) {
      // A listener must not take the worker down; there is nobody to report to here.
    }
  }
}

}  // namespace tracemesh::server
