#pragma once
/// @file local_job_coordinator.hpp
/// The jobs of one tracemeshd process (the default, no --store): accepted into the job store (a local directory,
/// or memory with --no-disk-store) before the 202, run by this process's job queue. See job_coordinator.hpp.

#include <mutex>

#include "server/jobs/job_coordinator.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/storage/job_store.hpp"

namespace tracemesh::server {

class local_job_coordinator final : public job_coordinator {
 public:
  /// Both must outlive this object.
  local_job_coordinator(job_queue& jobs, job_store& store) : jobs_(jobs), store_(store) {}

  /// The store holds the job (record + input) before the queue runs it; a job the queue refuses is forgotten
  /// again. A store write failure is accept_result::error.
  accept_result accept(const std::string& id, std::shared_ptr<const job_input> input,
                       const std::string& owner_hash) override;
  /// The queue's record (a done job with the stored report, which has the encodings made since it ended), else the
  /// job store's for finished jobs the queue forgot. Reads the job store (disk).
  result<std::optional<job_snapshot>> find(const std::string& id) override;
  std::optional<job_snapshot> find_in_memory(const std::string& id) override { return jobs_.find(id); }
  withdraw_result withdraw(const std::string& id, const std::string& owner_hash) override;
  bool blocking_lookups() const override { return false; }
  std::optional<std::string> unready_reason() const override { return std::nullopt; }
  bool durable() const override { return store_.durable(); }

 private:
  job_queue& jobs_;
  job_store& store_;
  // Serialises accept() (job store record + queue submit), so concurrent submissions of one job never overwrite
  // each other's owners.
  std::mutex accept_mutex_;
};

}  // namespace tracemesh::server
