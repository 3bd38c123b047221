#pragma once
/// @file job_queue.hpp
/// Bounded job queue with single-flight by job id, a pool of worker threads and a lane of workers reserved for
/// small jobs (job_queue_options::small_job_workers).
///
/// A job is identified by its id (the content hash of its canonical input, see job_id.hpp). Submitting an id that
/// is already queued or running attaches to that job instead of creating another ("coalesced"), so identical
/// concurrent submissions run the work once. Each job carries a progress_token: the work reports progress through
/// it and stops once it is cancelled — by cancel() (DELETE), by the per-job timeout (a watchdog thread flips the
/// token) or by shutdown() at the end of its grace period. The work itself is injected (job_work), so the queue can
/// be tested with a fake mesher and latches.
///
/// Listeners are called exactly once per job, on a worker thread (or the cancelling/shutting-down thread), after
/// the job reached its final state and outside the queue's lock; they must not block.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "core/mesher.hpp"
#include "core/molecule.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"
#include "proto/api_types.hpp"
#include "proto/report_json.hpp"
#include "server/jobs/eta_estimator.hpp"
#include "server/observability/metrics.hpp"

namespace tracemesh::server {

using proto::job_state;  // queued → running → done | failed | cancelled, named as in the API

/// What a job meshes: immutable once submitted, shared by every client of the job.
struct job_input {
  molecule mol;
  mesh_params params;
  /// The format asked for by the submission that created the job: GET /jobs/{id}/mesh serves it when the
  /// request names no format. Not part of the job id (one job produces every encoding).
  proto::mesh_format format = proto::mesh_format::off;
  /// What the submission that created the job read: its format and where the radii came from (the report's
  /// "input"). Not part of the job id either: the same atoms sent in another format are the same job.
  std::optional<proto::input_summary> input;
};

/// job_snapshot::error_code values set by the queue itself (other failures carry the errc_name of their status).
namespace job_error {
inline constexpr const char* cancelled = "cancelled";  ///< DELETE /jobs/{id}; the job ends as cancelled
inline constexpr const char* timeout = "timeout";      ///< ran past job_timeout; the job ends as failed
inline constexpr const char* shutdown = "shutdown";    ///< not finished at the end of the shutdown grace period
}  // namespace job_error

/// What a done job produced: the certified mesh and the report (JSON text), shared with the responses that encode
/// and send them (encodings are made per format on demand and cached, see mesh_job.hpp).
struct job_output {
  std::shared_ptr<const surface_mesh> mesh;
  std::shared_ptr<const std::string> report;
  bool from_cache = false;  ///< the work found the result stored and did not mesh
};

/// A consistent copy of a job's state.
struct job_snapshot {
  std::string id;
  job_state state = job_state::queued;
  double progress = 0;                    ///< 0..1 over the whole pipeline; never decreases
  mesh_stage stage = mesh_stage::reading;
  std::size_t queue_position = 0;         ///< jobs ahead of this one (queued jobs only; 0 = next)
  proto::mesh_format format = proto::mesh_format::off;  ///< job_input::format
  std::string error_code;                 ///< failed/cancelled: a job_error value or an errc_name
  status error;                           ///< failed/cancelled: the reason in words
  std::shared_ptr<const std::string> report;  ///< done jobs: the report JSON text
  double seconds = 0;                     ///< run time so far (running) or in total (final states)
  /// Expected seconds left (eta_estimator): running jobs once progress is past eta_estimator::min_progress; 0
  /// when done; nullopt otherwise (queued, failed, cancelled, or too early to tell).
  std::optional<double> eta_seconds;
};

/// The work of one job. Must poll `token` (through report()/cancelled()) and return errc::cancelled once it is
/// cancelled. May throw; an exception fails the job with errc::internal_error.
using job_work = std::function<result<job_output>(const std::string& id, const job_input& input,
                                                  progress_token& token)>;
/// Called once when the job is final; `output` is non-null only for done jobs.
using job_listener = std::function<void(const job_snapshot& final_state, const job_output* output)>;

struct job_queue_options {
  unsigned workers = 1;
  std::size_t max_queue = 64;         ///< queued (not running) jobs
  std::size_t max_records = 4096;     ///< finished jobs remembered for find()
  std::chrono::milliseconds job_timeout{std::chrono::minutes(10)};
  /// The small-job lane: this many extra workers take only queued jobs of at most small_job_max_atoms atoms
  /// (oldest first), so a small job never waits behind big ones that hold every general worker. General workers
  /// take every job, oldest first. 0 = no lane.
  unsigned small_job_workers = 0;
  std::size_t small_job_max_atoms = 20000;
};

enum class submit_outcome { accepted, coalesced, queue_full, shutting_down };

/// Who holds a job: an owner token's hash (POST /jobs), or nobody named (a synchronous /mesh waiter, which holds
/// the job until it ends). A job is cancelled only when no holder is left.
struct job_holder {
  std::string owner_hash;  ///< empty: an anonymous waiter
};

/// How a job is submitted: `recovered` jobs (re-queued from the job store at start) are queued past max_queue.
struct submit_options {
  std::optional<job_holder> holder;
  bool recovered = false;
};

struct submit_result {
  submit_outcome outcome;
  job_snapshot snapshot;  ///< of the new or joined job (empty id when refused)
};

/// DELETE by an owner: `withdrawn` when other holders keep the job running, `not_owner` when the token holds no
/// share of the job.
enum class cancel_outcome { cancelled, withdrawn, not_owner, not_found, already_final };

class job_queue {
 public:
  /// Starts `options.workers` worker threads and the timeout watchdog. `stats` must outlive the queue.
  /// `on_final` (optional) is called for every job that reaches a final state, before its listeners.
  job_queue(job_queue_options options, job_work work, metrics& stats, job_listener on_final = {});
  ~job_queue();  ///< shutdown with no grace period
  job_queue(const job_queue&) = delete;
  job_queue& operator=(const job_queue&) = delete;

  /// Queues job `id`, or joins it when it is queued or running (a finished record is replaced: failed jobs are
  /// retried, and done jobs re-run their work, which finds its results in the cache). `listener` (optional) is
  /// called when the job is final. Refused with queue_full when max_queue jobs wait, shutting_down after shutdown().
  submit_result submit(const std::string& id, std::shared_ptr<const job_input> input, job_listener listener = {},
                       submit_options how = {});

  /// Adds a listener to a queued or running job; false (listener not kept) when the job is unknown or final.
  bool subscribe(const std::string& id, job_listener listener);

  /// The job's state, while it is active or among the last max_records finished jobs.
  std::optional<job_snapshot> find(const std::string& id) const;

  /// How many listeners wait for the queued or running job `id` to end (each synchronous request that created or
  /// joined it); 0 when the job is unknown or final. Lets a caller know that every request has joined a job.
  std::size_t listeners(const std::string& id) const;

  /// Cancels a queued job at once, or asks a running job to stop (it then ends as cancelled).
  cancel_outcome cancel(const std::string& id);
  /// Withdraws the owner `owner_hash` from the job; the job is cancelled (as cancel()) when it was the last holder.
  cancel_outcome withdraw(const std::string& id, const std::string& owner_hash);

  /// Stops accepting jobs, lets queued and running jobs finish for up to `grace`, then cancels what is left
  /// (final state failed, error "shutdown") and joins the threads. Idempotent; returns when every thread is joined.
  void shutdown(std::chrono::milliseconds grace);

  bool accepting() const;
  std::size_t queue_depth() const;
  std::size_t running_jobs() const;

 private:
  struct job;
  enum class stop_reason { none, user, timeout, shutdown };

  void worker_loop(bool small_lane);
  /// The job a worker takes next: the oldest queued one, or for the small lane the oldest small one (end() when
  /// there is none). Needs mutex_.
  std::deque<std::shared_ptr<job>>::iterator next_for(bool small_lane);
  void watchdog_loop();
  void run(const std::shared_ptr<job>& j);
  void finish(const std::shared_ptr<job>& j, result<job_output> outcome);
  cancel_outcome cancel_locked(std::unique_lock<std::mutex>& lock, const std::shared_ptr<job>& target);
  void remember_finished(const std::shared_ptr<job>& j);  // needs mutex_
  job_snapshot snapshot_of(const job& j) const;            // needs mutex_
  void notify(std::vector<job_listener> listeners, const job_snapshot& final_state, const job_output* output) const;

  const job_queue_options options_;
  const job_work work_;
  metrics& metrics_;
  const job_listener on_final_;

  mutable std::mutex mutex_;
  std::condition_variable work_available_;
  std::condition_variable idle_or_stopping_;  // signalled when a job finishes and at stop
  std::unordered_map<std::string, std::shared_ptr<job>> jobs_;  // active and remembered finished jobs
  std::deque<std::shared_ptr<job>> queue_;
  std::vector<std::shared_ptr<job>> running_;
  std::deque<std::shared_ptr<job>> finished_;  // oldest first, bounded by max_records
  bool accepting_ = true;
  bool stopping_ = false;  // workers and watchdog exit
  std::vector<std::thread> workers_;
  std::thread watchdog_;
  bool joined_ = false;
  std::mutex shutdown_mutex_;  // serialises shutdown() callers
};

}  // namespace tracemesh::server
