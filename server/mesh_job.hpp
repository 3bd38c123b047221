#pragma once
/// @file mesh_job.hpp
/// The work of one job (job_queue's job_work): cache first, else mesh, encode every format of the format table,
/// build the report (which states every encoding's outcome) and store them all in the result cache. Runs on a worker thread (it blocks on CPU and disk).

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <spdlog/logger.h>

#include "core/limits.hpp"
#include "core/mesher.hpp"
#include "server/job_queue.hpp"
#include "server/metrics.hpp"
#include "server/result_cache.hpp"

namespace tracemesh::server {

/// The mesher entry point, injectable so that tests can run the service with a fake or slow mesher.
using mesher_function = std::function<result<mesh_output>(const molecule&, const mesh_params&, const mesh_limits&,
                                                          progress_token&)>;

struct mesh_job_context {
  result_cache& cache;
  metrics& stats;
  spdlog::logger& log;
  mesh_limits limits;
  unsigned mesher_threads = 0;  ///< mesh_params::threads for every run
  mesher_function mesher;       ///< tracemesh::mesh_molecule in production
};

/// The job's artifacts from the cache when the report and every encoding it lists are there (output.from_cache),
/// else a mesher run
/// (counted in metrics::mesher_runs) followed by encoding and caching. Errors: the mesher's (cancelled when the
/// token was cancelled). A format that refuses the mesh (limit_exceeded...) is in output.refused, not an error of the
/// job. A cache write failure is logged and does not fail the job: the result is
/// still served, just not persisted.
/// Why the job's report says `format` was not encoded (its "encodings" entry has an error), or nullopt when it was
/// encoded (or the report does not parse).
std::optional<status> refused_encoding(const std::string& report, proto::mesh_format format);

result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token);

}  // namespace tracemesh::server
