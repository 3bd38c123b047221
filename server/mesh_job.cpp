#include "server/mesh_job.hpp"

#include <chrono>
#include <span>
#include <string_view>

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
  for (const proto::mesh_format_info& row : proto::mesh_formats()) {
    if (std::optional<status> refused = refused_encoding(*output.report, row.format)) {
      output.refused.emplace(row.format, *std::move(refused));
    } else if (auto bytes = cache.get(mesh_key(id, row.format))) {
      output.meshes.emplace(row.format, std::move(bytes));
    } else {
      return std::nullopt;
    }
  }
  output.from_cache = true;
  return output;
}

/// The errc whose errc_name is `name` (internal_error for an unknown name).
errc errc_named(std::string_view name) {
  for (errc code : {errc::invalid_input, errc::nothing_to_mesh, errc::invalid_argument, errc::limit_exceeded,
                    errc::cancelled, errc::io_error}) {
    if (name == errc_name(code)) return code;
  }
  return errc::internal_error;
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

std::optional<status> refused_encoding(const std::string& report, proto::mesh_format format) {
  const nlohmann::json doc = nlohmann::json::parse(report, nullptr, false);
  if (!doc.is_object()) return std::nullopt;
  const auto encodings = doc.find("encodings");
  if (encodings == doc.end() || !encodings->is_object()) return std::nullopt;
  const auto entry = encodings->find(std::string(proto::format_name(format)));
  if (entry == encodings->end() || !entry->is_object() || !entry->contains("error")) return std::nullopt;
  const nlohmann::json& error = (*entry)["error"];
  return status(errc_named(error.value("code", "")), error.value("message", "this format cannot carry the mesh"));
}

result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token) {
  if (auto cached = cached_output(context.cache, id)) return *std::move(cached);

  mesh_params params = input.params;
  params.threads = context.mesher_threads;
  context.stats.count_mesher_run();
  const auto started = std::chrono::steady_clock::now();
  result<mesh_output> meshed = context.mesher(input.mol, params, context.limits, token);
  if (!meshed.ok()) return meshed.error();

  // Every format of the table, each from the same encoder_input (Draco's checked encoding serves draco and glb).
  const proto::encoder_input encoder(meshed->mesh);
  const std::span<const proto::mesh_format_info> formats = proto::mesh_formats();
  job_output output;
  nlohmann::json report = proto::report_to_json(*meshed, input.params);
  nlohmann::json& encodings = report["encodings"] = nlohmann::json::object();
  nlohmann::json sizes = nlohmann::json::object();
  for (std::size_t i = 0; i < formats.size(); ++i) {
    if (!token.report(mesh_stage::encoding, static_cast<double>(i) / static_cast<double>(formats.size()))) {
      return status(errc::cancelled, "cancelled");
    }
    const proto::mesh_format format = formats[i].format;
    result<std::string> bytes = formats[i].encode(encoder);
    if (!bytes && bytes.error().code() != errc::limit_exceeded) return bytes.error();  // a bug, not a refusal
    const result<std::size_t> size = bytes ? result<std::size_t>(bytes->size()) : result<std::size_t>(bytes.error());
    encodings[std::string(formats[i].name)] = proto::encoding_to_json(encoder, format, size);
    sizes[std::string(formats[i].name)] = bytes ? nlohmann::json(bytes->size()) : nlohmann::json(nullptr);
    if (bytes) {
      output.meshes.emplace(format, share(std::move(*bytes)));
    } else {
      output.refused.emplace(format, bytes.error());
    }
  }
  token.report(mesh_stage::encoding, 1.0);
  output.report = share(report.dump());

  // The report goes last: its presence marks a complete set of artifacts.
  for (const auto& [format, bytes] : output.meshes) store(context, id, mesh_key(id, format), *bytes);
  store(context, id, report_key(id), *output.report);

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  log_event(context.log, spdlog::level::info, "mesh_done",
            {{"job", id},
             {"atoms", input.mol.atoms.size()},
             {"vertices", meshed->mesh.vertex_count()},
             {"triangles", meshed->mesh.triangle_count()},
             {"bytes", sizes},
             {"certified", meshed->certified},
             {"seconds", seconds}});
  return output;
}

}  // namespace tracemesh::server
