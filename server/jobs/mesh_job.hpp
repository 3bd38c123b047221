#pragma once
/// @file mesh_job.hpp
/// The work of one job (job_queue's job_work): the stored result when the job store has one, else mesh, build the
/// report and store mesh + report once in the job store. Encodings are made per format on request from that one
/// mesh (encoded_result) through the format table's encoders (Draco: checked after decoding, bits raised until it
/// passes), cached, and stated in the stored report's `encodings` when first made, refusals included, so a format
/// that cannot carry the mesh is refused again from the report without encoding. No format of a done job can be
/// missing while another is served: they all come from the one stored mesh.
/// Runs on a worker thread or the prep pool (it blocks on CPU and disk).

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <spdlog/logger.h>

#include "core/limits.hpp"
#include "core/mesher.hpp"
#include "server/http/content_coding.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/storage/job_record_store.hpp"
#include "server/storage/job_store.hpp"
#include "server/observability/metrics.hpp"
#include "server/storage/result_cache.hpp"

namespace tracemesh::server {

/// The mesher entry point, injectable so that tests can run the service with a fake or slow mesher.
using mesher_function = std::function<result<mesh_output>(const molecule&, const mesh_params&, const mesh_limits&,
                                                          progress_token&)>;

struct mesh_job_context {
  result_cache& cache;
  job_record_store& store;  ///< job_store, or redis_job_store for replicas
  metrics& stats;
  spdlog::logger& log;
  mesh_limits limits;
  unsigned mesher_threads = 0;  ///< mesh_params::threads for every run
  mesher_function mesher;       ///< tracemesh::mesh_molecule in production
};

/// The job's stored mesh and report when the job store has them (output.from_cache), else a mesher run (counted
/// in metrics::mesher_runs) whose mesh and report (with an empty `encodings`: no format is encoded yet) are stored
/// in the job store before the job is done.
/// Meshing needs the store's claim_run() first: a job another replica is meshing is waited for and its result
/// returned (output.from_cache), so a job is meshed once across replicas.
/// Errors: the mesher's (cancelled when the token was cancelled); errc::io_error when the result cannot be stored
/// (a job is never done without a result that can be served for the whole retention period) or, for a job another
/// replica meshed, cannot be read.
result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token);

/// A done job's mesh in one format.
struct encoded_mesh {
  std::shared_ptr<const std::string> bytes;
  bool cache_hit = false;  ///< the bytes came from the result cache (no encoding was made)
};

/// The bytes of a done job's mesh in `format`: the cached encoding; else, unless the stored report says the format
/// refused this mesh, `mesh` (or, when null, the job store's mesh) encoded, its `encodings` entry added to the
/// stored report, and the bytes cached. Errors: errc::invalid_argument "no mesh" when the job has no stored result
/// (unknown, unfinished or expired); errc::io_error when the store says the job is done but its mesh cannot be read
/// (the result was lost); the format's refusal (limit_exceeded: this format cannot carry the mesh faithfully) from
/// the encoder or the report; the encoder's other errors.
result<encoded_mesh> encoded_result(const mesh_job_context& context, const std::string& id,
                                    proto::mesh_format format, std::shared_ptr<const surface_mesh> mesh = nullptr);

/// The cache key of a done job's mesh in `format` compressed with `coding`: mesh_key(id, format) +
/// coding_cache_suffix ("<id>.off.br4w22_b1_0_9"; identity: mesh_key itself).
std::string coded_mesh_key(const std::string& id, proto::mesh_format format, content_coding coding);

/// encoded_result's bytes as sent with Content-Encoding `coding`: for gzip and br, the cached compressed bytes, else
/// encoded_result's bytes compressed now (counted in metrics), cached under coded_mesh_key and returned (cache_hit
/// says whether the compressed bytes came from the cache). identity: encoded_result itself. Errors: encoded_result's;
/// the compressor's (errc::internal_error).
result<encoded_mesh> coded_result(const mesh_job_context& context, const std::string& id, proto::mesh_format format,
                                  content_coding coding, std::shared_ptr<const surface_mesh> mesh = nullptr);

/// Why the job's report says `format` was not encoded (its "encodings" entry has an error), or nullopt when it was
/// encoded or not tried yet (or the report does not parse).
std::optional<status> refused_encoding(const std::string& report, proto::mesh_format format);

}  // namespace tracemesh::server
