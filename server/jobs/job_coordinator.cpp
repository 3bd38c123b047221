#include "server/jobs/job_coordinator.hpp"

#include "server/storage/job_store.hpp"

namespace tracemesh::server {

stored_job accepted_record(const std::string& id, const job_input& input, const std::string& owner_hash) {
  stored_job record;
  record.id = id;
  record.parameters = proto::canonical_parameters(input.params);
  record.format = input.format;
  record.owners = {owner_hash};
  record.accepted_ms = unix_millis();
  return record;
}

job_snapshot snapshot_from_record(const stored_job& record) {
  job_snapshot job;
  job.id = record.id;
  job.state = record.state;
  job.format = record.format;
  job.progress = record.state == job_state::done ? 1.0 : 0.0;
  job.stage = record.state == job_state::done ? mesh_stage::done : mesh_stage::reading;
  if (record.state == job_state::done) job.eta_seconds = 0.0;
  job.error_code = record.error_code;
  if (!record.error_code.empty()) job.error = status(errc::cancelled, record.error_message);
  job.report = record.report;
  return job;
}

}  // namespace tracemesh::server
