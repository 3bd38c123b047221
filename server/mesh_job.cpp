#include "server/mesh_job.hpp"

#include <chrono>

#include "proto/mesh_encoders.hpp"
#include "proto/report_json.hpp"
#include "server/job_id.hpp"
#include "server/logging.hpp"

namespace tracemesh::server {

namespace {

std::shared_ptr<const std::string> share(std::string bytes) {
  return std::make_shared<const std::string>(std::move(bytes));
}

std::optional<job_output> cached_output(result_cache& cache, const std::string& id) {
  job_output output;
  output.report = cache.get(report_key(id));
  if (!output.report) return std::nullopt;
  output.off = cache.get(off_key(id));
  output.draco = cache.get(draco_key(id));
  if (!output.off || !output.draco) return std::nullopt;
  output.from_cache = true;
  return output;
}

void store(const mesh_job_context& context, const std::string& id, const std::string& key,
           const std::string& bytes) {
  const status stored = context.cache.put(key, bytes);
  if (!stored.ok()) {
    log_event(context.log, spdlog::level::err, "cache_write_failed",
              {{"job", id}, {"key", key}, {"bytes", bytes.size()}, {"error", stored.message()}});
  }
}

}  // namespace

result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token) {
  if (auto cached = cached_output(context.cache, id)) return *std::move(cached);

  mesh_params params = input.params;
  params.threads = context.mesher_threads;
  context.stats.count_mesher_run();
  const auto started = std::chrono::steady_clock::now();
  result<mesh_output> meshed = context.mesher(input.mol, params, context.limits, token);
  if (!meshed.ok()) return meshed.error();

  if (!token.report(mesh_stage::encoding, 0.0)) return status(errc::cancelled, "cancelled");
  result<std::string> off = proto::encode_mesh(meshed->mesh, proto::mesh_format::off);
  if (!off.ok()) return off.error();
  if (!token.report(mesh_stage::encoding, 0.5)) return status(errc::cancelled, "cancelled");
  result<std::string> draco = proto::encode_mesh(meshed->mesh, proto::mesh_format::draco);
  if (!draco.ok()) return draco.error();
  const std::string report = proto::report_to_json(*meshed, input.params).dump();
  token.report(mesh_stage::encoding, 1.0);

  // The report goes last: its presence marks a complete set of artifacts.
  store(context, id, off_key(id), *off);
  store(context, id, draco_key(id), *draco);
  store(context, id, report_key(id), report);

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  log_event(context.log, spdlog::level::info, "mesh_done",
            {{"job", id},
             {"atoms", input.mol.atoms.size()},
             {"vertices", meshed->mesh.vertex_count()},
             {"triangles", meshed->mesh.triangle_count()},
             {"off_bytes", off->size()},
             {"draco_bytes", draco->size()},
             {"certified", meshed->certified},
             {"seconds", seconds}});

  job_output output;
  output.off = share(std::move(*off));
  output.draco = share(std::move(*draco));
  output.report = share(report);
  return output;
}

}  // namespace tracemesh::server
