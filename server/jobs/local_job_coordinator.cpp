#include "server/jobs/local_job_coordinator.hpp"

namespace tracemesh::server {

accept_result local_job_coordinator::accept(const std::string& id, std::shared_ptr<const job_input> input,
                                            const std::string& owner_hash) {
  std::lock_guard accepting(accept_mutex_);
  const std::optional<stored_job> stored = store_.find(id);
  const bool already_queued = stored && stored->state == job_state::queued;
  status recorded = status::success();
  if (already_queued) {
    recorded = store_.add_owner(id, owner_hash);
  } else {
    recorded = store_.accept(accepted_record(id, *input, owner_hash), *input);
  }
  if (!recorded.ok()) return {submit_outcome::shutting_down, {}, recorded};
  submit_result submitted = jobs_.submit(id, std::move(input), {}, submit_options{job_holder{owner_hash}, false});
  const bool refused =
      submitted.outcome == submit_outcome::queue_full || submitted.outcome == submit_outcome::shutting_down;
  if (refused && !already_queued) store_.forget(id);
  return {submitted.outcome, std::move(submitted.snapshot), status::success()};
}

result<std::optional<job_snapshot>> local_job_coordinator::find(const std::string& id) {
  if (std::optional<job_snapshot> job = jobs_.find(id)) {
    if (job->state == job_state::done) {
      if (const std::optional<stored_job> stored = store_.find(id); stored && stored->report) {
        job->report = stored->report;
      }
    }
    return job;
  }
  if (std::optional<stored_job> stored = store_.find(id)) return std::optional(snapshot_from_record(*stored));
  return std::optional<job_snapshot>{};
}

withdraw_result local_job_coordinator::withdraw(const std::string& id, const std::string& owner_hash) {
  const cancel_outcome outcome = jobs_.withdraw(id, owner_hash);
  std::optional<job_snapshot> job = jobs_.find(id);
  if (outcome == cancel_outcome::not_found || outcome == cancel_outcome::already_final) {
    if (!job) {
      if (const std::optional<stored_job> stored = store_.find(id)) job = snapshot_from_record(*stored);
    }
    return {outcome, std::move(job), status::success()};
  }
  if (outcome != cancel_outcome::not_owner) store_.remove_owner(id, owner_hash);
  return {outcome, std::move(job), status::success()};
}

}  // namespace tracemesh::server
