#include "server/jobs/mesh_job.hpp"

#include <chrono>
#include <string_view>

#include "proto/api_types.hpp"
#include "proto/mesh_encoders.hpp"
#include "proto/report_json.hpp"
#include "server/jobs/job_id.hpp"
#include "server/observability/logging.hpp"

namespace tracemesh::server {

namespace {

/// The errc whose errc_name is `name` (internal_error for an unknown name).
errc errc_named(std::string_view name) {
  for (errc code : {errc::invalid_input, errc::nothing_to_mesh, errc::invalid_argument, errc::limit_exceeded,
                    errc::cancelled, errc::io_error}) {
    if (name == errc_name(code)) return code;
  }
  return errc::internal_error;
}

/// Encodes `mesh` in `format` and states the outcome in the stored report. A refusal (limit_exceeded) is
/// recorded too, so that the next request is refused from the report without encoding again. `recorded` tells
/// whether the report now states this encoding (bytes the report does not describe must not be cached).
result<std::string> encode_and_record(const mesh_job_context& context, const std::string& id,
                                      proto::mesh_format format, const surface_mesh& mesh, bool& recorded) {
  const auto started = std::chrono::steady_clock::now();
  const proto::encoder_input encoder(mesh);
  result<std::string> bytes = proto::format_info(format).encode(encoder);
  if (!bytes && bytes.error().code() != errc::limit_exceeded) return bytes.error();  // a bug, not a refusal
  const result<std::size_t> size = bytes ? result<std::size_t>(bytes->size()) : result<std::size_t>(bytes.error());
  const nlohmann::json entry = proto::encoding_to_json(encoder, format, size);
  const std::string_view name = proto::format_name(format);
  const status amended = context.store.record_encoding(id, name, entry);
  recorded = amended.ok();
  // A job the store does not hold (a memory store forgot it) has no report to amend; a write failure is an error.
  if (!amended.ok() && amended.code() != errc::invalid_argument) {
    log_event(context.log, spdlog::level::err, "job_store_write_failed",
              {{"job", id}, {"format", name}, {"error", amended.message()}});
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  log_event(context.log, spdlog::level::info, "mesh_encoded",
            {{"job", id},
             {"format", name},
             {"bytes", bytes ? nlohmann::json(bytes->size()) : nlohmann::json(nullptr)},
             {"recorded", recorded},
             {"seconds", seconds}});
  return bytes;
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

namespace {

/// The stored result of a done job, when the store has it whole.
std::optional<job_output> stored_output(const mesh_job_context& context, const std::optional<stored_job>& stored) {
  if (!stored || stored->state != job_state::done || !stored->report) return std::nullopt;
  if (auto mesh = context.store.mesh(stored->id)) return job_output{std::move(mesh), stored->report, true};
  return std::nullopt;
}

/// Ends a run granted by claim_run() when the work returns.
class run_claim {
 public:
  run_claim(job_record_store& store, const std::string& id) : store_(store), id_(id) {}
  ~run_claim() { store_.end_run(id_); }
  run_claim(const run_claim&) = delete;
  run_claim& operator=(const run_claim&) = delete;

 private:
  job_record_store& store_;
  const std::string& id_;
};

}  // namespace

result<job_output> run_mesh_job(const mesh_job_context& context, const std::string& id, const job_input& input,
                                progress_token& token) {
  if (auto output = stored_output(context, context.store.find(id))) return *std::move(output);
  const result<bool> claimed = context.store.claim_run(id, token);
  if (!claimed.ok()) return claimed.error();
  if (!*claimed) {  // another replica meshed it while this one waited
    if (auto output = stored_output(context, context.store.find(id))) return *std::move(output);
    return status(errc::io_error, "another replica meshed the job but its result cannot be read");
  }
  const run_claim claim(context.store, id);
  // Finished by another replica between the first look and the claim.
  const std::optional<stored_job> stored = context.store.find(id);
  if (auto output = stored_output(context, stored)) return *std::move(output);

  mesh_params params = input.params;
  params.threads = context.mesher_threads;
  context.stats.count_mesher_run();
  const auto started = std::chrono::steady_clock::now();
  result<mesh_output> meshed = context.mesher(input.mol, params, context.limits, token);
  if (!meshed.ok()) return meshed.error();
  if (meshed->trace.grid_retries > 0) {
    context.stats.count_trace_grid_retries(meshed->trace.grid_retries);
    log_event(context.log, spdlog::level::info, "trace_grid_retries",
              {{"job", id}, {"retries", meshed->trace.grid_retries}, {"seconds", meshed->failed_attempt_seconds}});
  }
  if (!meshed->fallback_reason.empty()) {
    context.stats.count_trace_fallback();
    log_event(context.log, spdlog::level::warn, "trace_fallback", {{"job", id}, {"reason", meshed->fallback_reason}});
  }
  if (!token.report(mesh_stage::encoding, 0.0)) return status(errc::cancelled, "cancelled");
  nlohmann::json report_doc = proto::report_to_json(*meshed, input.params, input.input);
  // Filled as formats are first encoded (encoded_result). A result made again after the store lost its mesh keeps
  // the entries already known: the mesh is the same (deterministic), and so are the cached encodings they describe.
  report_doc["encodings"] = nlohmann::json::object();
  if (stored && stored->report) {
    const nlohmann::json before = nlohmann::json::parse(*stored->report, nullptr, false);
    if (before.is_object() && before.contains("encodings") && before["encodings"].is_object()) {
      report_doc["encodings"] = before["encodings"];
    }
  }
  auto report = std::make_shared<const std::string>(report_doc.dump());

  stored_job record;
  record.id = id;
  record.parameters = proto::canonical_parameters(input.params);
  record.format = input.format;
  record.accepted_ms = unix_millis();
  const status completed = context.store.complete(id, record, meshed->mesh, report);
  if (!completed.ok()) {
    log_event(context.log, spdlog::level::err, "job_store_write_failed",
              {{"job", id}, {"error", completed.message()}});
    return status(errc::io_error, "the result could not be stored: " + completed.message());
  }
  token.report(mesh_stage::encoding, 1.0);

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  log_event(context.log, spdlog::level::info, "mesh_done",
            {{"job", id},
             {"atoms", input.mol.atoms.size()},
             {"vertices", meshed->mesh.vertex_count()},
             {"triangles", meshed->mesh.triangle_count()},
             {"method", method_name(method_used(meshed->method, *meshed))},
             {"certified", meshed->certified},
             {"seconds", seconds}});
  return job_output{std::make_shared<const surface_mesh>(std::move(meshed->mesh)), std::move(report), false};
}

result<encoded_mesh> encoded_result(const mesh_job_context& context, const std::string& id,
                                    proto::mesh_format format, std::shared_ptr<const surface_mesh> mesh) {
  const std::string key = mesh_key(id, format);
  if (auto cached = context.cache.get(key)) return encoded_mesh{std::move(cached), true};
  const std::optional<stored_job> stored = context.store.find(id);
  if (stored && stored->report) {
    if (std::optional<status> refused = refused_encoding(*stored->report, format)) return *std::move(refused);
  }
  if (!mesh) mesh = context.store.mesh(id);
  if (!mesh) {
    if (stored && stored->state == job_state::done) {
      return status(errc::io_error, "the job is done but the job store cannot read its mesh");
    }
    return status(errc::invalid_argument, "no mesh");
  }
  bool recorded = false;
  result<std::string> encoded = encode_and_record(context, id, format, *mesh, recorded);
  if (!encoded.ok()) return encoded.error();
  auto bytes = std::make_shared<const std::string>(std::move(*encoded));
  // Cached only once the report states it (a cache hit then always has its entry). The cache only saves work: a
  // failed write loses nothing, the store keeps the mesh.
  if (!recorded) return encoded_mesh{std::move(bytes), false};
  if (const status put = context.cache.put(key, *bytes); !put.ok()) {
    log_event(context.log, spdlog::level::warn, "cache_write_failed",
              {{"job", id}, {"key", key}, {"bytes", bytes->size()}, {"error", put.message()}});
  }
  return encoded_mesh{std::move(bytes), false};
}

std::string coded_mesh_key(const std::string& id, proto::mesh_format format, content_coding coding) {
  return mesh_key(id, format) + coding_cache_suffix(coding);
}

result<encoded_mesh> coded_result(const mesh_job_context& context, const std::string& id, proto::mesh_format format,
                                  content_coding coding, std::shared_ptr<const surface_mesh> mesh) {
  if (coding == content_coding::identity) return encoded_result(context, id, format, std::move(mesh));
  const std::string key = coded_mesh_key(id, format, coding);
  if (auto cached = context.cache.get(key)) return encoded_mesh{std::move(cached), true};
  result<encoded_mesh> plain = encoded_result(context, id, format, std::move(mesh));
  if (!plain.ok()) return plain.error();
  result<std::string> compressed = compress(*plain->bytes, coding);
  if (!compressed.ok()) return compressed.error();
  context.stats.count_mesh_compression(coding == content_coding::br);
  auto bytes = std::make_shared<const std::string>(std::move(*compressed));
  // Like the encodings themselves: the cache only saves work, a failed write loses nothing.
  if (const status put = context.cache.put(key, *bytes); !put.ok()) {
    log_event(context.log, spdlog::level::warn, "cache_write_failed",
              {{"job", id}, {"key", key}, {"bytes", bytes->size()}, {"error", put.message()}});
  }
  return encoded_mesh{std::move(bytes), false};
}

}  // namespace tracemesh::server
