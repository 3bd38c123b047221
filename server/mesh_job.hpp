#pragma once
/// @file mesh_job.hpp
/// The work of one job (job_queue's job_work): the stored result when the job store has one, else mesh, build the
/// report and store mesh + report once in the job store. Encodings are made per format on demand from that one
/// mesh (encoded_result) and cached, so no format of a done job can be missing while another is served.
/// Runs on a worker thread (it blocks on CPU and disk).

#include <functional>
#include <memory>
#include <string>

#include <spdlog/logger.h>

#include "core/limits.hpp"
#include "core/mesher.hpp"
#include "server/job_queue.hpp"
#include "server/job_store.hpp"
#include "server/metrics.hpp"
#include "server/result_cache.hpp"

namespace tracemesh::server {

/// The mesher entry point, injectable so that tests can run the service with a fake or slow mesher.
using mesher_function = std::function<result<mesh_output>(const molecule&, const mesh_params&, const mesh_limits&,
                                                          progress_token&)>;

struct mesh_job_context {
  result_cache& cache;
  job_store& store;
  metrics& stats;
  spdlog::logger& log;
  mesh_limits limits;
  unsigned mesher_threads = 0;  ///< mesh_params::threads for every run
  mesher_function mesher;       ///< tracemesh::mesh_molecule in production
};

/// The job's stored mesh and report when the job store has them (output.from_cache), else a mesher run (counted
/// in metrics::mesher_runs) whose mesh and report are stored in the job store before the job is done.
/// Errors: the mesher's (cancelled when the token was cancelled); errc::io_error when the result cannot be stored
/// (a job is never done without a result that can be served for the whole retention period).
result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token);

/// The bytes of a done job's mesh in `format`: the cached encoding, else `mesh` (or, when null, the job store's
/// mesh) encoded and cached. `cache_hit` tells which. Errors: errc::invalid_argument "no mesh" when the job
/// has no stored result; the encoder's error (e.g. limit_exceeded) otherwise.
result<std::shared_ptr<const std::string>> encoded_result(const mesh_job_context& context, const std::string& id,
                                                          proto::mesh_format format,
                                                          std::shared_ptr<const surface_mesh> mesh,
                                                          bool* cache_hit = nullptr);

/// The cache key of a job's encoding in `format` ("<id>.off", "<id>.drc"...).
std::string encoding_key(const std::string& id, proto::mesh_format format);

}  // namespace tracemesh::server
