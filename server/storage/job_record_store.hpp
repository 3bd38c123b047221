#pragma once
/// @file job_record_store.hpp
/// What the work of a job (mesh_job.hpp) reads and writes about it: the job's record, its stored mesh, the
/// encodings made of that mesh, and the right to mesh it. Two implementations:
///   job_store        one process: a local directory (or memory), records and meshes side by side;
///   redis_job_store  replicas of `tracemeshd --store redis://…`: records in Redis, meshes in the content-addressed
///                    result store on the directory every replica mounts, and a run lease per job so that a job is
///                    meshed once however many replicas are asked for it.
/// Threading: every member is thread-safe and may block (disk, network): call from workers and the prep pool.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"
#include "proto/api_types.hpp"
#include "proto/mesh_format.hpp"

namespace tracemesh::server {

using proto::job_state;

/// What the store knows of a job.
struct stored_job {
  std::string id;
  job_state state = job_state::queued;  ///< queued (accepted, not final yet), done, failed or cancelled
  std::string parameters;               ///< proto::canonical_parameters of the job's mesh_params
  proto::mesh_format format = proto::mesh_format::off;  ///< the format of the submission that created it
  std::vector<std::string> owners;      ///< SHA-256 (hex) of each owner token still holding the job
  std::string error_code;               ///< failed/cancelled
  std::string error_message;
  std::shared_ptr<const std::string> report;  ///< done: the report JSON text
  std::int64_t accepted_ms = 0;               ///< Unix time in ms
  std::int64_t finished_ms = 0;               ///< Unix time in ms; 0 while unfinished
};

class job_record_store {
 public:
  virtual ~job_record_store() = default;

  /// The job's record while it is retained; std::nullopt when unknown, expired or (Redis) unreadable.
  virtual std::optional<stored_job> find(const std::string& id) = 0;
  /// A done job's mesh; nullptr when unknown, expired or unreadable.
  virtual std::shared_ptr<const surface_mesh> mesh(const std::string& id) = 0;
  /// A done job: stores the mesh and the report, then marks the record done (creating it when the job was never
  /// accepted, e.g. a synchronous /mesh job). errc::io_error when either cannot be stored.
  virtual status complete(const std::string& id, const stored_job& record_if_new, const surface_mesh& mesh,
                          std::shared_ptr<const std::string> report) = 0;
  /// States in the done job's report that `format_name` was encoded: `entry` (proto::encoding_to_json) becomes
  /// report.encodings.<format_name>; concurrent calls never lose one another. errc::invalid_argument when the job
  /// is not done (or unknown); errc::io_error when the write fails.
  virtual status record_encoding(const std::string& id, std::string_view format_name,
                                 const nlohmann::json& entry) = 0;
  /// Called before meshing job `id`: true when this process is to mesh it now; false when another process has
  /// meshed it meanwhile (find() and mesh() then give the result). May wait while another process meshes it,
  /// polling `token`: errc::cancelled when the token is cancelled meanwhile. A single process always gets true.
  virtual result<bool> claim_run(const std::string& /*id*/, progress_token& /*token*/) { return true; }
  /// After a run that claim_run() granted ended, whatever its outcome.
  virtual void end_run(const std::string& /*id*/) {}
};

/// `report` (a JSON object's text) with encodings.<name> set to `entry`; `report` unchanged when it is not a JSON
/// object.
std::string with_encoding(const std::string& report, std::string_view name, const nlohmann::json& entry);

}  // namespace tracemesh::server
