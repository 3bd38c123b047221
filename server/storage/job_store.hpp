#pragma once
/// @file job_store.hpp
/// Accepted work, kept apart from the evictable result cache: one record per job (state, parameters, owners,
/// error, report), the input of every unfinished job, and the certified mesh of every done job, kept for a
/// retention period counted from the job's end whatever the cache does. Encodings (OFF, Draco...) are not stored
/// here: they are made on demand from the one stored mesh and cached (so all formats of a result stand or fall
/// together: there is one mesh or none).
///
/// With a directory (durable): <dir>/<first two hex digits>/<id>.record | .input | .result, each a sealed file
/// (magic, length, SHA-256) written by temp file + fsync + rename + directory fsync (detail/durable_file.hpp).
/// Write order makes every crash point safe:
///   accept:   .input, then .record (queued)            — the 202 is sent after both are durable
///   complete: .result, then .record (done), then the .input is removed
///   finish:   .record (failed | cancelled), then the .input is removed
/// At open(), records still queued (or done without a readable result) are handed back by take_unfinished() with
/// their input, to be queued again; one whose input is lost or damaged ends failed with error "lost" (logged by
/// the caller). One directory belongs to one server process.
///
/// Without a directory (--no-disk-store): the same in memory, bounded by memory_bytes (the oldest finished jobs
/// are forgotten first); nothing survives a restart, and the service says so in /readyz and its logs.
///
/// Threading: every member is thread-safe; file I/O runs on the calling thread (workers and the prep pool).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh.hpp"
#include "core/status.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/storage/job_record_store.hpp"

namespace tracemesh::server {

struct job_store_options {
  std::filesystem::path dir;  ///< empty: memory only (not durable)
  /// How long a finished job's record and result are kept after it ended (--job-retention).
  std::chrono::milliseconds retention{std::chrono::hours(24)};
  /// Memory-only store: bytes of meshes and reports held (--job-store-memory-bytes); the oldest finished jobs are
  /// forgotten past it.
  std::size_t memory_bytes = std::size_t{1} << 30;
};


/// An unfinished job found at open(): to be queued again.
struct unfinished_job {
  stored_job record;
  std::shared_ptr<const job_input> input;
};

/// job_snapshot::error_code of a job whose stored input or result was found unusable at start.
inline constexpr const char* lost_job_error = "lost";

class job_store final : public job_record_store {
 public:
  explicit job_store(job_store_options options);
  job_store(const job_store&) = delete;
  job_store& operator=(const job_store&) = delete;

  /// Durable store: creates and probes the directory (errc::io_error, one line, when it is not a usable
  /// directory), removes temporary files of killed writers, loads the records, drops expired ones and collects
  /// the unfinished jobs for take_unfinished(). Memory store: nothing to do.
  status open();
  bool durable() const noexcept { return !options_.dir.empty(); }
  const job_store_options& options() const noexcept { return options_; }

  /// The unfinished jobs found by open() (each handed out once), and the ids of jobs found lost.
  std::vector<unfinished_job> take_unfinished();
  std::vector<std::string> take_lost();

  /// Records a newly accepted job (state queued) and its input. Must succeed before the job is acknowledged.
  status accept(const stored_job& record, const job_input& input);
  /// Forgets a job accepted by accept() that the queue then refused (429/503): it was never acknowledged.
  void forget(const std::string& id);
  /// Adds an owner (token hash) to a job's record (a later submission of the same content).
  status add_owner(const std::string& id, const std::string& owner_hash);
  /// Removes an owner; false when it was not an owner.
  bool remove_owner(const std::string& id, const std::string& owner_hash);

  /// A done job: stores the mesh and the report, then marks the record done (creating it when the job was never
  /// accepted through accept(), e.g. a synchronous /mesh job) and drops the input.
  status complete(const std::string& id, const stored_job& record_if_new, const surface_mesh& mesh,
                  std::shared_ptr<const std::string> report) override;
  /// A done job's report rewritten by `amend` (given the current report text, returns the new one), under the
  /// writers' lock so that amendments never lose one another; durable before it returns. Used to add an encoding's
  /// entry when a format is first encoded. errc::invalid_argument when the job is not done (or unknown).
  status amend_report(const std::string& id, const std::function<std::string(const std::string&)>& amend);
  /// amend_report with with_encoding.
  status record_encoding(const std::string& id, std::string_view format_name, const nlohmann::json& entry) override;
  /// A failed or cancelled job: marks its record (when it has one) and drops the input.
  status finish(const std::string& id, job_state state, const std::string& error_code,
                const std::string& error_message);

  /// The job's record while it is retained (expired records are forgotten on the way).
  std::optional<stored_job> find(const std::string& id) override;
  /// A done job's mesh (read from disk for a durable store; nullptr when unknown, expired or unreadable).
  std::shared_ptr<const surface_mesh> mesh(const std::string& id) override;

  /// Forgets jobs that ended more than `retention` ago (records, results, inputs).
  void purge_expired();

  std::size_t records() const;

 private:
  std::filesystem::path file_path(const std::string& id, std::string_view extension) const;
  status write_record(const stored_job& record);
  void forget_locked(const std::string& id);
  void enforce_memory_bound_locked();
  bool expired(const stored_job& record, std::int64_t now_ms) const;

  const job_store_options options_;
  // Serialises the writers of records (accept, complete, finish, owners) so each sees the last record written:
  // a job completing while it is accepted again can never be set back to queued.
  std::mutex write_mutex_;
  mutable std::mutex mutex_;  // the index below
  std::map<std::string, stored_job> records_;
  // Memory store only: the meshes of done jobs, numbered in the order they were completed (finished_ms has
  // millisecond ties), and their bytes.
  struct held_mesh {
    std::shared_ptr<const surface_mesh> mesh;
    std::uint64_t completion = 0;
  };
  std::map<std::string, held_mesh> meshes_;
  std::uint64_t completions_ = 0;
  std::size_t memory_used_ = 0;
  std::vector<unfinished_job> unfinished_;
  std::vector<std::string> lost_;
};

/// Serialises a mesh to bytes and back (little-endian arrays: positions, normals, atom indices, triangles);
/// std::nullopt for malformed bytes.
std::string serialize_mesh(const surface_mesh& mesh);
std::optional<surface_mesh> deserialize_mesh(std::string_view bytes);
/// The same for a job's input (atoms and zero-radius count); the parameters travel in the record.
std::string serialize_molecule(const molecule& mol);
std::optional<molecule> deserialize_molecule(std::string_view bytes);
/// "density=1;d=-1;..." (proto::canonical_parameters) back to mesh_params; errc::invalid_input when malformed.
result<mesh_params> parse_canonical_parameters(const std::string& text);

/// Unix time now, in milliseconds.
std::int64_t unix_millis();

}  // namespace tracemesh::server
