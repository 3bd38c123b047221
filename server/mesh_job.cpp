#include "server/mesh_job.hpp"

#include <chrono>

#include "proto/api_types.hpp"
#include "proto/mesh_encoders.hpp"
#include "proto/report_json.hpp"
#include "server/logging.hpp"

namespace tracemesh::server {

std::string encoding_key(const std::string& id, proto::mesh_format format) {
  return id + "." + std::string(proto::file_extension(format)).substr(1);
}

result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token) {
  if (const std::optional<stored_job> stored = context.store.find(id);
      stored && stored->state == job_state::done && stored->report) {
    if (auto mesh = context.store.mesh(id)) return job_output{std::move(mesh), stored->report, true};
  }

  mesh_params params = input.params;
  params.threads = context.mesher_threads;
  context.stats.count_mesher_run();
  const auto started = std::chrono::steady_clock::now();
  result<mesh_output> meshed = context.mesher(input.mol, params, context.limits, token);
  if (!meshed.ok()) return meshed.error();
  if (!token.report(mesh_stage::encoding, 0.0)) return status(errc::cancelled, "cancelled");
  auto report = std::make_shared<const std::string>(proto::report_to_json(*meshed, input.params).dump());

  stored_job record;
  record.id = id;
  record.parameters = proto::canonical_parameters(input.params);
  record.format = input.format;
  record.accepted_ms = unix_millis();
  const status stored = context.store.complete(id, record, meshed->mesh, report);
  if (!stored.ok()) {
    log_event(context.log, spdlog::level::err, "job_store_write_failed", {{"job", id}, {"error", stored.message()}});
    return status(errc::io_error, "the result could not be stored: " + stored.message());
  }
  token.report(mesh_stage::encoding, 1.0);

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  log_event(context.log, spdlog::level::info, "mesh_done",
            {{"job", id},
             {"atoms", input.mol.atoms.size()},
             {"vertices", meshed->mesh.vertex_count()},
             {"triangles", meshed->mesh.triangle_count()},
             {"certified", meshed->certified},
             {"seconds", seconds}});
  return job_output{std::make_shared<const surface_mesh>(std::move(meshed->mesh)), std::move(report), false};
}

result<std::shared_ptr<const std::string>> encoded_result(const mesh_job_context& context, const std::string& id,
                                                          proto::mesh_format format,
                                                          std::shared_ptr<const surface_mesh> mesh,
                                                          bool* cache_hit) {
  const std::string key = encoding_key(id, format);
  if (auto cached = context.cache.get(key)) {
    if (cache_hit) *cache_hit = true;
    return cached;
  }
  if (cache_hit) *cache_hit = false;
  if (!mesh) mesh = context.store.mesh(id);
  if (!mesh) return status(errc::invalid_argument, "no mesh");
  result<std::string> encoded = proto::encode_mesh(*mesh, format);
  if (!encoded.ok()) return encoded.error();
  auto bytes = std::make_shared<const std::string>(std::move(*encoded));
  // The cache only saves work: a failed write loses nothing, the store keeps the mesh.
  if (const status put = context.cache.put(key, *bytes); !put.ok()) {
    log_event(context.log, spdlog::level::warn, "cache_write_failed",
              {{"job", id}, {"key", key}, {"bytes", bytes->size()}, {"error", put.message()}});
  }
  return bytes;
}

}  // namespace tracemesh::server
