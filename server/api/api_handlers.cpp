#include "server/api/api_handlers.hpp"

#include <algorithm>
#include <cctype>
#include <array>
#include <chrono>
#include <map>
#include <optional>
#include <span>
#include <utility>

#include <boost/asio/post.hpp>
#include <boost/beast/core/string.hpp>
#include <boost/beast/http/rfc7230.hpp>
#include <boost/range/iterator_range.hpp>
#include <nlohmann/json.hpp>

#include "core/atom_resolution.hpp"
#include "core/io/pqr_reader.hpp"
#include "core/io/structure/molecule_reader.hpp"
#include "proto/api_types.hpp"
#include "proto/openapi.hpp"
#include "server/http/byte_range.hpp"
#include "server/http/content_coding.hpp"
#include "server/storage/content_hash.hpp"
#include "server/jobs/job_id.hpp"
#include "server/observability/logging.hpp"
#include "server/jobs/mesh_job.hpp"
#include "server/http/web_assets.hpp"

namespace tracemesh::server {

// ---- routing ------------------------------------------------------------------------------------------------

// Outside the anonymous namespace: api_handlers::upload_request, a class with linkage, holds one.
enum class route_id {
  healthz, readyz, metrics, openapi, web_page, favicon, web_asset, mesh, jobs, job, job_mesh, job_events, unknown
};

namespace {

using clock = std::chrono::steady_clock;

struct route_match {
  route_id id = route_id::unknown;
  std::string job_id;  // raw path segment for job routes (validated by the handler)
};

struct route_info {
  const char* name;     // metrics label
  const char* allowed;  // Allow header
};

route_info info(route_id id) {
  switch (id) {
    case route_id::healthz: return {"/healthz", "GET, HEAD, OPTIONS"};
    case route_id::readyz: return {"/readyz", "GET, HEAD, OPTIONS"};
    case route_id::metrics: return {"/metrics", "GET, HEAD, OPTIONS"};
    case route_id::openapi: return {"/openapi.json", "GET, HEAD, OPTIONS"};
    case route_id::web_page: return {"/", "GET, HEAD, OPTIONS"};
    case route_id::favicon: return {"/favicon.ico", "GET, HEAD, OPTIONS"};
    case route_id::web_asset: return {"/assets/{build}/{file}", "GET, HEAD, OPTIONS"};
    case route_id::mesh: return {"/mesh", "POST, OPTIONS"};
    case route_id::jobs: return {"/jobs", "POST, OPTIONS"};
    case route_id::job: return {"/jobs/{id}", "GET, HEAD, DELETE, OPTIONS"};
    case route_id::job_mesh: return {"/jobs/{id}/mesh", "GET, HEAD, OPTIONS"};
    case route_id::job_events: return {"/jobs/{id}/events", "GET, OPTIONS"};
    case route_id::unknown: break;
  }
  return {"(unknown)", ""};
}

bool method_allowed(route_id id, http::verb method) {
  if (method == http::verb::options) return true;
  switch (id) {
    case route_id::healthz:
    case route_id::readyz:
    case route_id::metrics:
    case route_id::openapi:
    case route_id::web_page:
    case route_id::favicon:
    case route_id::web_asset:
    case route_id::job_mesh: return method == http::verb::get || method == http::verb::head;
    case route_id::mesh:
    case route_id::jobs: return method == http::verb::post;
    case route_id::job:
      return method == http::verb::get || method == http::verb::head || method == http::verb::delete_;
    case route_id::job_events: return method == http::verb::get;
    case route_id::unknown: break;
  }
  return false;
}

route_match match_route(std::string_view path) {
  if (path == "/healthz") return {route_id::healthz, {}};
  if (path == "/readyz") return {route_id::readyz, {}};
  if (path == "/metrics") return {route_id::metrics, {}};
  if (path == "/openapi.json") return {route_id::openapi, {}};
  if (path == "/") return {route_id::web_page, {}};
  if (path == "/favicon.ico") return {route_id::favicon, {}};
  if (path.substr(0, 8) == "/assets/") return {route_id::web_asset, {}};
  if (path == "/mesh") return {route_id::mesh, {}};
  if (path == "/jobs") return {route_id::jobs, {}};
  constexpr std::string_view jobs_prefix = "/jobs/";
  if (path.substr(0, jobs_prefix.size()) != jobs_prefix) return {};
  std::string_view rest = path.substr(jobs_prefix.size());
  for (const auto& [suffix, id] : {std::pair<std::string_view, route_id>{"/mesh", route_id::job_mesh},
                                   std::pair<std::string_view, route_id>{"/events", route_id::job_events}}) {
    if (rest.size() > suffix.size() && rest.substr(rest.size() - suffix.size()) == suffix) {
      rest.remove_suffix(suffix.size());
      if (rest.find('/') != std::string_view::npos) return {};
      return {id, std::string(rest)};
    }
  }
  if (rest.empty() || rest.find('/') != std::string_view::npos) return {};
  return {route_id::job, std::string(rest)};
}

struct target_parts {
  std::string_view path;
  std::string_view query;
};

/// Origin-form targets only ("/path?query"); "*", absolute-form and empty targets are refused.
/// The path and query of a request target in origin form ("/mesh?x=1") or absolute form ("http://host/mesh?x=1",
/// which RFC 9112 §3.2.2 says a server must accept; the authority is ignored, as is Host for routing); nothing for
/// any other form ("*", "host:port", a relative path).
std::optional<target_parts> split_target(std::string_view target) {
  for (const std::string_view scheme : {"http://", "https://"}) {
    if (target.size() < scheme.size() || !std::equal(scheme.begin(), scheme.end(), target.begin(),
                                                     [](char a, char b) { return a == std::tolower(static_cast<unsigned char>(b)); })) {
      continue;
    }
    const std::string_view rest = target.substr(scheme.size());
    const auto path = rest.find_first_of("/?");
    if (path == std::string_view::npos) return target_parts{"/", {}};
    if (rest[path] == '?') return target_parts{"/", rest.substr(path + 1)};
    target = rest.substr(path);
    break;
  }
  if (target.empty() || target.front() != '/') return std::nullopt;
  const auto question = target.find('?');
  if (question == std::string_view::npos) return target_parts{target, {}};
  return target_parts{target.substr(0, question), target.substr(question + 1)};
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::optional<std::string> percent_decode(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '+') {
      out += ' ';
    } else if (text[i] == '%') {
      if (i + 2 >= text.size()) return std::nullopt;
      const int high = hex_value(text[i + 1]);
      const int low = hex_value(text[i + 2]);
      if (high < 0 || low < 0) return std::nullopt;
      out += static_cast<char>(high * 16 + low);
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

using parameter_map = std::map<std::string, std::string, std::less<>>;

/// A client's name, as an error message quotes it: at most 32 bytes.
std::string shown_name(const std::string& name) { return name.size() <= 32 ? name : name.substr(0, 32) + "..."; }

/// "a=1&b=2" → {a: 1, b: 2}. A repeated name or a bad escape is an error naming it.
result<parameter_map> parse_query(std::string_view query) {
  parameter_map out;
  while (!query.empty()) {
    const auto amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    if (pair.empty()) continue;
    const auto equals = pair.find('=');
    auto name = percent_decode(pair.substr(0, equals));
    auto value = percent_decode(equals == std::string_view::npos ? std::string_view{} : pair.substr(equals + 1));
    if (!name || !value) return status(errc::invalid_argument, "malformed percent-escape in the query string");
    if (out.contains(*name)) {
      return status(errc::invalid_argument, "query parameter '" + shown_name(*name) + "' given twice");
    }
    out.emplace(std::move(*name), std::move(*value));
  }
  return out;
}

/// Every name in `params` must be one of `known`; the error names the first stranger.
status only_known(const parameter_map& params, std::span<const std::string_view> known, const char* where) {
  for (const auto& [name, value] : params) {
    bool found = false;
    for (std::string_view k : known) found = found || name == k;
    if (!found) {
      return status(errc::invalid_argument, std::string("unknown ") + where + " '" + shown_name(name) + "'");
    }
  }
  return status::success();
}

status only_known(const parameter_map& params, std::initializer_list<std::string_view> known, const char* where) {
  return only_known(params, std::span<const std::string_view>(known.begin(), known.size()), where);
}

// ---- replies ------------------------------------------------------------------------------------------------

reply with_retry_after(reply r, unsigned seconds) {
  r.headers.emplace_back("Retry-After", std::to_string(seconds));
  return r;
}

reply status_error_reply(const status& error, std::string route) {
  return error_reply(static_cast<unsigned>(proto::http_status(error.code())), errc_name(error.code()),
                     error.message(), std::move(route));
}

/// The value of a request field, nullopt when absent.
std::optional<std::string_view> field_value(const request_head& head, http::field name) {
  const auto it = head.find(name);
  if (it == head.end()) return std::nullopt;
  return to_std(it->value());
}

/// The response coding of a mesh in `format` for this request (nullopt: 406).
std::optional<content_coding> mesh_coding(const std::optional<std::string>& accept, proto::mesh_format format) {
  return negotiate_coding(accept ? std::optional<std::string_view>(*accept) : std::nullopt,
                          proto::format_info(format).compressible);
}

std::string etag_for(const std::string& id, proto::mesh_format format, content_coding coding) {
  // The job id is the content hash of everything that determines the mesh (engine version included) and the
  // encoders are deterministic, so id + format names the bytes exactly; a compressed representation adds its
  // compressor, level and library version (content_coding_etag_tag), so each strong tag names one byte sequence.
  std::string tag = "\"" + id + "-" + std::string(proto::format_name(format));
  if (coding != content_coding::identity) tag += "." + content_coding_etag_tag(coding);
  return tag + "\"";
}

/// Responses whose bytes depend on Accept-Encoding say so to caches.
void add_vary(reply& r, proto::mesh_format format) {
  if (proto::format_info(format).compressible) r.headers.emplace_back("Vary", "Accept-Encoding");
}

/// 406: the request refuses identity and the format has no other coding.
reply not_acceptable_reply(proto::mesh_format format, std::string route) {
  reply r = error_reply(406, "not_acceptable",
                        "Accept-Encoding refuses every coding this response can have (" +
                            std::string(proto::format_name(format)) + " is sent as " +
                            (proto::format_info(format).compressible ? "identity, gzip or br" : "identity only") + ")",
                        std::move(route));
  add_vary(r, format);
  return r;
}

/// The mesh bytes (encoded in `format`, compressed with `coding`) with their headers. `immutable`: the URL always
/// names these bytes (a long Cache-Control); otherwise caches must revalidate with the ETag.
reply mesh_reply(const std::string& id, proto::mesh_format format, content_coding coding,
                 std::shared_ptr<const std::string> bytes, bool cache_hit, std::string route, bool immutable = true) {
  reply r;
  r.route = std::move(route);
  r.content_type = std::string(proto::content_type(format));
  r.body = std::move(bytes);
  r.headers.emplace_back("ETag", etag_for(id, format, coding));
  if (coding != content_coding::identity) r.headers.emplace_back("Content-Encoding", std::string(coding_name(coding)));
  add_vary(r, format);
  r.headers.emplace_back("X-Cache", cache_hit ? "hit" : "miss");
  r.headers.emplace_back("X-Job-Id", id);
  // A generated name: the upload's filename is never echoed.
  r.headers.emplace_back("Content-Disposition", "attachment; filename=\"" + id.substr(0, 12) +
                                                    std::string(proto::file_extension(format)) + "\"");
  r.headers.emplace_back("Cache-Control", immutable ? "public, max-age=31536000, immutable" : "no-cache");
  return r;
}

reply not_modified(const std::string& id, proto::mesh_format format, content_coding coding, std::string route) {
  reply r;
  r.status = 304;
  r.route = std::move(route);
  r.headers.emplace_back("ETag", etag_for(id, format, coding));
  add_vary(r, format);
  r.headers.emplace_back("X-Job-Id", id);
  return r;
}

/// GET /jobs/{id}/mesh: the Range decision (with If-Range against `etag`) on the bytes selected, compressed ones
/// included (as nginx serves ranges of a gzip_static file): 206 with one slice of the body, 416, or `r` whole.
/// Ranges are answered for GET only (RFC 9110 §14.2): a HEAD gets the 200 headers.
reply with_range(reply r, const request_head& head, const std::string& etag) {
  r.headers.emplace_back("Accept-Ranges", "bytes");
  if (head.method() != http::verb::get) return r;
  const std::uint64_t size = r.body->size();
  const range_decision decision =
      decide_range(field_value(head, http::field::range), field_value(head, http::field::if_range), etag, size);
  switch (decision.outcome) {
    case range_outcome::full: return r;
    case range_outcome::partial:
      r.status = 206;
      r.body_slice = std::pair<std::size_t, std::size_t>(decision.range.first, decision.range.length);
      r.headers.emplace_back("Content-Range", content_range(decision, size));
      return r;
    case range_outcome::unsatisfiable: break;
  }
  reply refused = error_reply(416, "range_not_satisfiable",
                              "the range starts at or past the end of the " + std::to_string(size) + " bytes",
                              std::move(r.route));
  refused.headers.emplace_back("Content-Range", content_range(decision, size));
  refused.headers.emplace_back("Accept-Ranges", "bytes");
  for (const auto& [name, value] : r.headers) {
    if (name == "ETag" || name == "Vary" || name == "X-Job-Id") refused.headers.emplace_back(name, value);
  }
  return refused;
}

/// OPTIONS * (RFC 9110 §9.3.7): what the server as a whole supports.
reply server_options_reply() {
  reply r;
  r.status = 204;
  r.route = "*";
  r.headers.emplace_back("Allow", "GET, HEAD, POST, DELETE, OPTIONS");
  return r;
}

/// If-Match (RFC 9110 §13.1.1) refuses the request: the field is present and neither "*" nor a list holding
/// `etag` (strong comparison: a weak tag never matches).
bool if_match_fails(const request_head& head, const std::string& etag) {
  const auto fields = head.equal_range(http::field::if_match);
  if (fields.first == fields.second) return false;
  for (const auto& field : boost::make_iterator_range(fields)) {
    std::string_view list = to_std(field.value());
    while (!list.empty()) {
      const std::size_t comma = list.find(',');
      std::string_view tag = list.substr(0, comma);
      list = comma == std::string_view::npos ? std::string_view() : list.substr(comma + 1);
      while (!tag.empty() && (tag.front() == ' ' || tag.front() == '\t')) tag.remove_prefix(1);
      while (!tag.empty() && (tag.back() == ' ' || tag.back() == '\t')) tag.remove_suffix(1);
      if (tag == "*" || tag == etag) return false;
    }
  }
  return true;
}

reply precondition_failed_reply(const std::string& etag, std::string route) {
  reply r = error_reply(412, "precondition_failed", "If-Match names no current representation (the ETag is " +
                                                        etag + ")",
                        std::move(route));
  r.headers.emplace_back("ETag", etag);
  return r;
}

bool etag_matches(const request_head& head, const std::string& etag) {
  const std::string_view wanted = to_std(head[http::field::if_none_match]);
  if (wanted.empty()) return false;
  if (wanted == "*") return true;
  // A list of entity tags: "a", W/"b", ...
  return wanted.find(etag) != std::string_view::npos;
}

/// The page may load only what this server serves: its bundle, the Draco decoder's worker (a blob: URL made by
/// DRACOLoader) and WebAssembly compiled from the decoder's bytes.
constexpr const char* web_page_security_policy =
    "default-src 'self'; script-src 'self' 'wasm-unsafe-eval' blob:; worker-src 'self' blob:; "
    "img-src 'self' data: blob:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'";

/// A file of the web viewer (server/http/web_assets.hpp), 304 on a matching If-None-Match.
reply web_asset_reply(const request_head& head, std::string_view path, const char* route) {
  const web_asset* asset = find_web_asset(path);
  if (!asset) return error_reply(404, "not_found", "the web viewer has no such file", route);
  if (if_match_fails(head, asset->etag)) return precondition_failed_reply(asset->etag, route);
  reply r;
  r.route = route;
  if (etag_matches(head, asset->etag)) {
    r.status = 304;
  } else {
    r.content_type = std::string(asset->content_type);
    r.body = asset->body;
  }
  r.headers.emplace_back("ETag", asset->etag);
  r.headers.emplace_back("Cache-Control", std::string(asset->cache_control));
  if (path == "/") r.headers.emplace_back("Content-Security-Policy", web_page_security_policy);
  return r;
}

/// The job's URLs; the mesh link names the format explicitly, so following it never depends on what the server
/// still remembers about the job.
nlohmann::json job_links(const std::string& id, proto::mesh_format format) {
  return {{"self", "/jobs/" + id},
          {"mesh", "/jobs/" + id + "/mesh?format=" + std::string(proto::format_name(format))}};
}

/// The Job document of openapi.json; the report (JSON text) is spliced in without re-parsing it.
std::string job_document(const job_snapshot& job) {
  nlohmann::json doc = nlohmann::json::object();
  doc["id"] = job.id;
  doc["status"] = std::string(proto::job_state_name(job.state));
  doc["progress"] = job.progress;
  doc["stage"] = job.state == job_state::queued ? nlohmann::json(nullptr) : nlohmann::json(stage_name(job.stage));
  doc["queue_position"] = job.state == job_state::queued ? nlohmann::json(job.queue_position) : nullptr;
  doc["seconds"] = job.seconds;
  doc["eta_s"] = job.eta_seconds ? nlohmann::json(*job.eta_seconds) : nlohmann::json(nullptr);
  doc["error"] = job.error_code.empty()
                     ? nlohmann::json(nullptr)
                     : nlohmann::json{{"code", job.error_code}, {"message", job.error.message()}};
  doc["links"] = job_links(job.id, job.format);
  std::string text = doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);  // never throws
  text.pop_back();  // the closing brace
  text += ",\"report\":";
  text += job.report ? *job.report : std::string("null");
  text += '}';
  return text;
}

/// One Server-Sent Event; every line of `data` gets its own "data:" field (the JSON documents are one line).
std::string sse_event(std::string_view name, std::string_view data) {
  std::string text = "event: " + std::string(name) + "\n";
  for (;;) {
    const auto newline = data.find('\n');
    text += "data: ";
    text += data.substr(0, newline);
    text += '\n';
    if (newline == std::string_view::npos) break;
    data.remove_prefix(newline + 1);
  }
  return text + '\n';
}

/// Holds one of limits.max_event_streams, and one of its client's max_event_streams_per_client, while it lives.
class event_stream_slot {
 public:
  event_stream_slot(std::atomic<std::size_t>& open, std::shared_ptr<client_lease> client)
      : open_(open), client_(std::move(client)) {}
  ~event_stream_slot() { open_.fetch_sub(1, std::memory_order_relaxed); }
  event_stream_slot(const event_stream_slot&) = delete;
  event_stream_slot& operator=(const event_stream_slot&) = delete;

 private:
  std::atomic<std::size_t>& open_;
  const std::shared_ptr<client_lease> client_;
};

/// The events of GET /jobs/{id}/events: a progress event at the first call and whenever the job's status, stage
/// or progress changed since the last one sent (the session calls at most every limits.event_interval); once the
/// job is final, its document from the records' side (as GET /jobs/{id}) as the last event, done or error.
/// A job this process holds in memory is looked at on the I/O thread; anything else (a finished job, or with the
/// Redis store a job another replica runs) on the prep pool (it may read the disk or ask Redis). With Redis, the
/// records are read only when the coordinator's change_version() moved (a published message: see
/// redis_job_events.hpp) or `fallback` passed since the last read; without that signal, at every call.
class job_event_source final : public event_source, public std::enable_shared_from_this<job_event_source> {
 public:
  job_event_source(job_coordinator& jobs, boost::asio::thread_pool& prep, std::string id,
                   std::unique_ptr<event_stream_slot> slot, std::chrono::milliseconds fallback)
      : jobs_(jobs), prep_(prep), id_(std::move(id)), slot_(std::move(slot)), fallback_(fallback) {}

  void next(std::function<void(batch)> deliver) override {
    const std::optional<job_snapshot> job = jobs_.find_in_memory(id_);
    if (job && !proto::is_final(job->state)) return deliver({progress_if_changed(*job), false});
    const std::optional<std::uint64_t> version = jobs_.change_version(id_);
    const auto now = std::chrono::steady_clock::now();
    if (version && read_ && *version == read_version_ && now < next_read_) return deliver({{}, false});
    // Taken before the read: a change published while it runs moves the version again.
    read_ = true;
    read_version_ = version.value_or(0);
    next_read_ = now + fallback_;
    boost::asio::post(prep_, [this, deliver = std::move(deliver), keep = shared_from_this()]() mutable {
      deliver(from_records());
    });
  }

 private:
  /// A progress event when the job changed since the last one sent (always the first time), else nothing.
  std::string progress_if_changed(const job_snapshot& job) {
    if (!first_ && job.state == last_state_ && job.stage == last_stage_ && job.progress == last_progress_) return {};
    first_ = false;
    last_state_ = job.state;
    last_stage_ = job.stage;
    last_progress_ = job.progress;
    return sse_event("progress", job_document(job));
  }

  batch from_records() {
    const result<std::optional<job_snapshot>> found = jobs_.find(id_);
    if (!found.ok()) return {{}, false};  // the records are unreachable for now: try again at the next call
    const std::optional<job_snapshot>& job = *found;
    if (!job) {
      return {sse_event("error", proto::error_body("not_found", "the job is no longer known").dump()), true};
    }
    std::string text = progress_if_changed(*job);
    if (!proto::is_final(job->state)) return {std::move(text), false};
    text += sse_event(job->state == job_state::done ? "done" : "error", job_document(*job));
    return {std::move(text), true};
  }

  job_coordinator& jobs_;
  boost::asio::thread_pool& prep_;
  const std::string id_;
  const std::unique_ptr<event_stream_slot> slot_;
  const std::chrono::milliseconds fallback_;
  // The session calls next() once at a time (the next call waits for the previous delivery).
  bool read_ = false;  // the records were read once (at read_version_, next due at next_read_ without a change)
  std::uint64_t read_version_ = 0;
  std::chrono::steady_clock::time_point next_read_{};
  bool first_ = true;
  job_state last_state_ = job_state::queued;
  mesh_stage last_stage_ = mesh_stage::reading;
  double last_progress_ = 0;
};

/// The owner token header of POST /jobs replies and DELETE /jobs/{id} requests.
constexpr const char* job_token_header = "X-Job-Token";

/// A final job that did not produce a mesh, as the error reply of a synchronous request: 409 cancelled by a
/// DELETE; 504 past the per-job deadline (the request waited its whole time budget; retrying the same input would
/// time out again, so no Retry-After); 503 + Retry-After at shutdown; else the status of the job's error.
reply job_failure_reply(const job_snapshot& job, std::string route, unsigned retry_after_seconds) {
  const std::string code = job.error_code.empty() ? std::string(errc_name(errc::internal_error)) : job.error_code;
  if (code == job_error::cancelled) return error_reply(409, code, job.error.message(), std::move(route));
  if (code == job_error::timeout) return error_reply(504, code, job.error.message(), std::move(route));
  if (code == job_error::shutdown) {
    return with_retry_after(error_reply(503, code, job.error.message(), std::move(route)), retry_after_seconds);
  }
  return error_reply(static_cast<unsigned>(proto::http_status(job.error.code())), code, job.error.message(),
                     std::move(route));
}

/// DELETE of a job that already finished: nothing to cancel.
reply already_finished_reply(job_state state, std::string route) {
  return error_reply(409, "conflict",
                     "the job already finished (" + std::string(proto::job_state_name(state)) +
                         "); there is nothing to cancel",
                     std::move(route));
}

enum class body_coding { identity, gzip };

/// The request body's Content-Encoding: none or "identity" → identity; one "gzip" (or "x-gzip") → gzip; anything
/// else (another coding, or several layers) → nullopt, answered 415 with Accept-Encoding (RFC 9110 §15.5.16).
std::optional<body_coding> request_body_coding(const request_head& head) {
  std::size_t gzip_layers = 0;
  for (const auto& field : boost::make_iterator_range(head.equal_range(http::field::content_encoding))) {
    for (const auto& coding : http::token_list{field.value()}) {
      if (boost::beast::iequals(coding, "identity")) continue;
      if (!boost::beast::iequals(coding, "gzip") && !boost::beast::iequals(coding, "x-gzip")) return std::nullopt;
      ++gzip_layers;
    }
  }
  if (gzip_layers > 1) return std::nullopt;
  return gzip_layers == 1 ? body_coding::gzip : body_coding::identity;
}

/// Client text quoted in a message: at most 32 bytes.
std::string shown(std::string_view text) {
  return text.size() <= 32 ? std::string(text) : std::string(text.substr(0, 32)) + "...";
}

bool starts_with_gzip_magic(std::string_view bytes) {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
         static_cast<unsigned char>(bytes[1]) == 0x8b;
}

const std::string* find_param(const parameter_map& params, std::string_view name) {
  const auto it = params.find(name);
  return it == params.end() ? nullptr : &it->second;
}



/// The multipart fields that carry the molecule file: "structure" (any format) and "pqr" (a PQR file).
bool is_file_field(std::string_view name) { return name == "structure" || name == "pqr"; }

/// The field 'pqr' declares PQR (the field 'structure' declares nothing): set in `options`, or refused when
/// format_in declares another format.
status declare_file_field_format(std::string_view field, structure_options& options) {
  if (field != "pqr") return status::success();
  if (options.format && options.format->format != input_format::pqr) {
    return status(errc::invalid_argument, "the file field 'pqr' declares pqr, but " + options.format->declared_by +
                                              "; send the file in the field 'structure'");
  }
  if (!options.format) options.format = declared_format{input_format::pqr, "the file field 'pqr'"};
  return status::success();
}

/// A parameter given both in the query and in the form must have the same value there: which one a server
/// would take is a guess a client should not have to make.
status same_in_query_and_form(const parameter_map& query, const parameter_map& form) {
  for (const auto& [name, value] : form) {
    const std::string* other = find_param(query, name);
    if (other && *other != value) {
      return status(errc::invalid_argument, "parameter '" + shown_name(name) + "' given in the query ('" +
                                                shown(*other) + "') and in the form ('" + shown(value) +
                                                "') with different values");
    }
  }
  return status::success();
}


/// Every parameter an upload route knows: the mesh request's and the input options.
std::span<const std::string_view> upload_fields() {
  static const auto fields = [] {
    std::array<std::string_view, proto::mesh_request_fields.size() + structure_option_names.size()> all{};
    std::copy(proto::mesh_request_fields.begin(), proto::mesh_request_fields.end(), all.begin());
    std::copy(structure_option_names.begin(), structure_option_names.end(),
              all.begin() + proto::mesh_request_fields.size());
    return all;
  }();
  return fields;
}


}  // namespace

// ---- the upload pipeline ------------------------------------------------------------------------------------

struct api_handlers::upload_request {
  route_id route;
  proto::mesh_request request;
  structure_options options;
  std::string pqr;  // the uploaded file (field 'pqr' or 'structure'), any input format
  content_coding coding = content_coding::identity;  // POST /mesh: the mesh bytes' negotiated coding
  std::shared_ptr<upload_ticket> ticket;  // released as soon as the upload has been parsed
  std::string client;                     // body_plan::client
  reply_sink done;
  clock::time_point received;
};

api_handlers::api_handlers(api_dependencies deps)
    : deps_(deps),
      uploads_(deps.config.limits.max_concurrent_uploads, deps.config.limits.max_upload_bytes_in_flight),
      client_uploads_(deps.config.limits.max_uploads_per_client),
      client_jobs_(deps.config.limits.max_jobs_per_client),
      client_event_streams_(deps.config.limits.max_event_streams_per_client),
      refusal_log_(deps.config.limits.refusal_log_interval, deps.config.limits.max_refusal_log_clients) {}

std::string api_handlers::client_key(const request_head& head, const std::string& client_address) const {
  const std::string_view authorization = to_std(head[http::field::authorization]);
  if (deps_.auth.enabled() && !authorization.empty()) return "token:" + token_digest(authorization);
  return "ip:" + client_address;
}

boost::asio::thread_pool& api_handlers::parsing_pool(std::size_t body_bytes, bool gzip_encoded) const {
  return gzip_encoded || body_bytes > deps_.config.limits.large_upload_bytes ? deps_.large_uploads : deps_.prep;
}

std::variant<reply, body_plan> api_handlers::plan(const request_head& head, const std::string& client_address) {
  if (head.method() == http::verb::options && head.target() == "*") return server_options_reply();
  const auto target = split_target(to_std(head.target()));
  if (!target) {
    return error_reply(400, "bad_request", "the request target must be an absolute path or an http(s) URL",
                       "(bad target)");
  }
  const route_match match = match_route(target->path);
  if (match.id == route_id::unknown) return error_reply(404, "not_found", "no such resource", "(unknown)");
  const route_info route = info(match.id);
  if (!method_allowed(match.id, head.method())) {
    reply r = error_reply(405, "method_not_allowed", "allowed methods: " + std::string(route.allowed), route.name);
    r.headers.emplace_back("Allow", route.allowed);
    return r;
  }
  if (head.method() == http::verb::options) {
    reply r;
    r.status = 204;
    r.route = route.name;
    r.headers.emplace_back("Allow", route.allowed);
    deps_.cors.add_preflight_headers(to_std(head[http::field::origin]), route.allowed, r.headers);
    return r;
  }

  if (auto refused = authorization_failure(head, route.name)) return *std::move(refused);

  const server_limits& limits = deps_.config.limits;
  const bool upload = match.id == route_id::mesh || match.id == route_id::jobs;
  const auto declared_length = head[http::field::content_length];
  std::uint64_t length = 0;
  const bool has_length = !declared_length.empty();
  if (has_length) length = std::strtoull(std::string(declared_length).c_str(), nullptr, 10);  // Beast validated it

  if (!upload) {
    if (has_length && length > limits.max_small_body_bytes) {
      return error_reply(413, "limit_exceeded", "this route takes no request body", route.name);
    }
    body_plan small;
    small.route = route.name;
    small.max_bytes = limits.max_small_body_bytes;
    small.client = client_key(head, client_address);
    return small;
  }

  if (deps_.state.draining.load()) {
    return with_retry_after(error_reply(503, "unavailable", "the server is shutting down", route.name),
                            limits.retry_after_seconds);
  }
  // 413 from Content-Length before reading a byte (and before any 100 Continue).
  if (has_length && length > limits.max_upload_bytes) {
    return error_reply(413, "limit_exceeded",
                       "the upload of " + std::to_string(length) + " bytes exceeds the limit of " +
                           std::to_string(limits.max_upload_bytes) + " bytes",
                       route.name);
  }
  const std::optional<body_coding> coding = request_body_coding(head);
  if (!coding) {
    reply r = error_reply(415, "unsupported_media_type",
                          "the request body's Content-Encoding must be gzip or identity, not '" +
                              shown(to_std(head[http::field::content_encoding])) + "'",
                          route.name);
    r.headers.emplace_back("Accept-Encoding", "gzip");
    return r;
  }
  const std::string_view content_type = to_std(head[http::field::content_type]);
  if (!is_multipart_form_data(content_type)) {
    return error_reply(415, "unsupported_media_type",
                       "the upload must be multipart/form-data with the molecule file in the field 'structure' "
                       "(or 'pqr')",
                       route.name);
  }
  result<std::string> boundary = multipart_boundary(content_type);
  if (!boundary.ok()) return error_reply(400, "invalid_input", boundary.error().message(), route.name);

  std::string client = client_key(head, client_address);
  std::shared_ptr<client_lease> client_upload = client_uploads_.acquire(client);
  if (!client_upload) {
    return client_limit_reply("max_uploads_per_client", limits.max_uploads_per_client, "uploads in progress",
                              limits.retry_after_seconds, route.name);
  }
  // Bytes are counted as they arrive (http_session), never from the declared Content-Length.
  std::shared_ptr<upload_ticket> ticket = uploads_.admit(0);
  if (!ticket) {
    return with_retry_after(error_reply(429, "queue_full", "too many uploads in progress", route.name),
                            limits.retry_after_seconds);
  }
  ticket->attach(std::move(client_upload));
  body_plan plan;
  plan.route = route.name;
  plan.upload = true;
  plan.gzip_encoded = *coding == body_coding::gzip;
  plan.max_bytes = limits.max_upload_bytes;
  plan.boundary = std::move(*boundary);
  plan.part_limits.max_parts = limits.max_form_parts;
  plan.part_limits.max_field_bytes = limits.max_form_field_bytes;
  plan.part_limits.max_file_bytes = limits.max_upload_bytes;
  plan.ticket = std::move(ticket);
  plan.client = std::move(client);
  return plan;
}

void api_handlers::handle(const request_head& head, const body_plan& plan, std::string, reply_sink done) {
  const auto target = split_target(to_std(head.target()));
  const route_match match = match_route(target->path);
  const char* route = info(match.id).name;
  result<parameter_map> query = parse_query(target->query);
  if (!query.ok()) return done(error_reply(400, "invalid_argument", query.error().message(), route));

  switch (match.id) {
    case route_id::healthz: return done(json_reply(200, R"({"status":"ok"})", route));
    case route_id::readyz: return done(readiness_reply());
    case route_id::metrics: return done(metrics_reply());
    case route_id::openapi: {
      reply r = json_reply(200, std::string(proto::openapi_document()), route);
      return done(std::move(r));
    }
    case route_id::web_page:
    case route_id::favicon:
    case route_id::web_asset: return done(web_asset_reply(head, target->path, route));
    case route_id::job:
    case route_id::job_mesh:
    case route_id::job_events: break;
    default: return done(error_reply(404, "not_found", "no such resource", route));
  }

  if (!is_valid_job_id(match.job_id)) {
    return done(error_reply(400, "invalid_argument", "a job id is 64 lower-case hex digits", route));
  }
  if (match.id == route_id::job) {
    if (const status known = only_known(*query, {}, "query parameter"); !known.ok()) {
      return done(error_reply(400, "invalid_argument", known.message(), route));
    }
    if (head.method() == http::verb::delete_) {
      return cancel_job(match.job_id, std::string(to_std(head[job_token_header])), std::move(done));
    }
    return job_status(match.job_id, std::move(done));
  }
  if (match.id == route_id::job_events) {
    if (const status known = only_known(*query, {}, "query parameter"); !known.ok()) {
      return done(error_reply(400, "invalid_argument", known.message(), route));
    }
    return job_events(match.job_id, plan.client, std::move(done));
  }
  if (const status known = only_known(*query, {"format"}, "query parameter"); !known.ok()) {
    return done(error_reply(400, "invalid_argument", known.message(), route));
  }
  std::optional<proto::mesh_format> format;
  if (const std::string* name = find_param(*query, "format")) {
    result<proto::mesh_format> parsed = proto::parse_mesh_format(*name);
    if (!parsed.ok()) return done(error_reply(400, "invalid_argument", parsed.error().message(), route));
    format = *parsed;
  }
  job_mesh(head, match.job_id, format, std::move(done));
}

void api_handlers::handle_upload(const request_head& head, body_plan plan, std::vector<multipart_part> parts,
                                 reply_sink done) {
  const auto target = split_target(to_std(head.target()));
  const route_match match = match_route(target->path);
  const std::string route = plan.route;
  result<parameter_map> query = parse_query(target->query);
  if (!query.ok()) return done(error_reply(400, "invalid_argument", query.error().message(), route));
  if (const status known = only_known(*query, upload_fields(), "query parameter"); !known.ok()) {
    return done(error_reply(400, "invalid_argument", known.message(), route));
  }

  // A parameter may come in the query or the form, or in both with the same value (openapi.json); the file
  // travels in "structure" (its format declared by format_in= or detected) or "pqr" (declared PQR).
  parameter_map form;
  multipart_part* file = nullptr;
  for (multipart_part& part : parts) {
    if (is_file_field(part.name)) {
      if (file) {
        return done(error_reply(400, "invalid_input", "give one file, in the field 'structure' or 'pqr'", route));
      }
      file = &part;
      continue;
    }
    if (part.filename) {
      return done(error_reply(400, "invalid_input", "only the field 'structure' (or 'pqr') may carry a file", route));
    }
    if (!form.emplace(part.name, part.body).second) {
      return done(error_reply(400, "invalid_argument", "form field '" + shown_name(part.name) + "' given twice", route));
    }
  }
  if (const status known = only_known(form, upload_fields(), "form field"); !known.ok()) {
    return done(error_reply(400, "invalid_argument", known.message(), route));
  }
  if (!file) return done(error_reply(400, "invalid_input", "missing the file field 'structure' (or 'pqr')", route));
  if (const status agreed = same_in_query_and_form(*query, form); !agreed.ok()) {
    return done(status_error_reply(agreed, route));
  }

  const proto::field_lookup lookup = [&](std::string_view name) -> std::optional<std::string> {
    if (const std::string* value = find_param(form, name)) return *value;
    if (const std::string* value = find_param(*query, name)) return *value;
    return std::nullopt;
  };
  result<proto::mesh_request> request = proto::parse_mesh_request(lookup);
  if (!request.ok()) return done(status_error_reply(request.error(), route));
  result<structure_options> options = parse_structure_options(lookup);
  if (!options.ok()) return done(status_error_reply(options.error(), route));
  if (const status declared = declare_file_field_format(file->name, *options); !declared.ok()) {
    return done(status_error_reply(declared, route));
  }

  // POST /mesh answers with mesh bytes: their coding is negotiated before any work is done.
  const std::optional<content_coding> coding =
      match.id == route_id::mesh ? mesh_coding(accept_encoding(head), request->format) : content_coding::identity;
  if (!coding) return done(not_acceptable_reply(request->format, route));
  auto upload = std::make_shared<upload_request>();
  upload->route = match.id;
  upload->request = *request;
  upload->options = *options;
  upload->pqr = std::move(file->body);
  upload->coding = *coding;
  upload->ticket = std::move(plan.ticket);
  upload->client = std::move(plan.client);
  upload->done = std::move(done);
  upload->received = clock::now();
  boost::asio::post(parsing_pool(upload->pqr.size(), false), [this, upload] { prepare_upload(upload); });
}

void api_handlers::handle_encoded_upload(const request_head& head, body_plan plan, std::string compressed_body,
                                         reply_sink done) {
  auto job = [this, head, plan = std::move(plan), compressed = std::move(compressed_body),
              done = std::move(done)]() mutable {
    const std::string route = plan.route;
    // On an error the upload is over: release its admission before answering (as prepare_upload does).
    const auto fail = [&](reply r) {
      plan.ticket.reset();
      done(std::move(r));
    };
    if (!starts_with_gzip_magic(compressed)) {
      return fail(error_reply(400, "invalid_input", "the body is declared Content-Encoding: gzip but is not gzip data",
                              route));
    }
    // The decoded body obeys the decompressed-size limit of a gzipped PQR file; so does its file part.
    const std::size_t max_decoded = deps_.config.limits.max_pqr_bytes;
    result<std::string> body = maybe_gunzip(compressed, max_decoded);
    std::string().swap(compressed);
    if (!body.ok()) {
      const std::string message = "Content-Encoding: gzip body: " + body.error().message();
      return fail(status_error_reply(status(body.error().code(), message), route));
    }
    multipart_limits part_limits = plan.part_limits;
    part_limits.max_file_bytes = max_decoded;
    multipart_parser parser(plan.boundary, part_limits);
    parser.set_body_size_hint(body->size());
    status parsed = parser.feed(*body);
    std::string().swap(*body);
    if (parsed.ok()) parsed = parser.finish();
    if (!parsed.ok()) {
      const bool too_large = parsed.code() == errc::limit_exceeded;
      return fail(error_reply(too_large ? 413 : 400, errc_name(parsed.code()), parsed.message(), route));
    }
    handle_upload(head, std::move(plan), std::move(parser.parts()), std::move(done));
  };
  boost::asio::post(parsing_pool(0, true), std::move(job));
}

bool api_handlers::is_health_route(std::string_view target) const {
  const auto parts = split_target(target);
  if (!parts) return false;
  const route_id id = match_route(parts->path).id;
  return id == route_id::healthz || id == route_id::readyz;
}

void api_handlers::prepare_upload(std::shared_ptr<upload_request> upload) {
  const char* route = info(upload->route).name;
  const std::size_t upload_bytes = upload->pqr.size();
  std::optional<proto::input_summary> input_read;
  result<molecule> mol = [&]() -> result<molecule> {
    result<read_molecule_result> read =
        read_molecule(upload->pqr, upload->options, deps_.config.limits.mesh, deps_.config.limits.max_pqr_bytes);
    std::string().swap(upload->pqr);
    if (!read.ok()) return read.error();
    input_read = proto::summarize_input(*read);
    // Refused here (422) rather than by the job: the client learns at once which atom is too small.
    if (status resolvable = check_atom_resolution(read->mol, upload->request.params); !resolvable) return resolvable;
    return std::move(read->mol);
  }();
  // The upload is over once parsed (its bytes are freed above): release its admission before anything can answer
  // the client, or a client that sends its next upload as soon as this one is answered could find the slot taken
  // (the job may finish and reply on a worker before this thread gets past submit()).
  upload->ticket.reset();
  if (!mol.ok()) {
    log_event(deps_.log, spdlog::level::info, "upload_rejected",
              {{"route", route}, {"bytes", upload_bytes}, {"error", errc_name(mol.error().code())}});
    return upload->done(status_error_reply(mol.error(), route));
  }
  const std::string id = compute_job_id(*mol, upload->request.params);
  const std::size_t atoms = mol->atoms.size();

  // A result already made (cached encoding, or the job store's mesh) is answered without a job.
  if (upload->route == route_id::mesh) {
    auto encoded = coded_result(deps_.results, id, upload->request.format, upload->coding);
    if (encoded.ok()) {
      deps_.stats.count_cache_response();
      return upload->done(
          mesh_reply(id, upload->request.format, upload->coding, std::move(encoded->bytes), true, route));
    }
    // A lost result is logged and made again by the job below; a refusal is the answer.
    if (encoded.error().code() == errc::io_error) {
      log_result_lost(id, upload->request.format, encoded.error().message());
    } else if (encoded.error().code() != errc::invalid_argument) {
      return upload->done(status_error_reply(encoded.error(), route));
    }
  } else if (const auto known = deps_.coordinator.find(id);
             known.ok() && *known && (*known)->state == job_state::done) {
    deps_.stats.count_cache_response();
    nlohmann::json accepted = {{"id", id}, {"status", "done"}, {"links", job_links(id, upload->request.format)}};
    reply r = json_reply(200, accepted.dump(), route);
    r.headers.emplace_back("Location", "/jobs/" + id);
    return upload->done(std::move(r));
  }

  // The job counts against its client until it ends (jobs it joined too: it holds them as well).
  std::shared_ptr<client_lease> client_job = client_jobs_.acquire(upload->client);
  if (!client_job) {
    const server_limits& limits = deps_.config.limits;
    return upload->done(client_limit_reply("max_jobs_per_client", limits.max_jobs_per_client,
                                           "jobs queued or running", limits.retry_after_seconds, route));
  }
  auto input = std::make_shared<job_input>();
  input->mol = std::move(*mol);
  input->params = upload->request.params;
  input->format = upload->request.format;
  input->input = std::move(input_read);
  job_listener listener;
  submit_options how;
  std::string owner_token;
  if (upload->route == route_id::mesh) {
    how.holder = job_holder{};  // the waiter holds the job until it ends
    listener = [done = upload->done, id, format = upload->request.format, coding = upload->coding,
                results = &deps_.results, client_job,
                retry = deps_.config.limits.retry_after_seconds](const job_snapshot& final_state,
                                                                 const job_output* output) {
      if (!output) return done(job_failure_reply(final_state, "/mesh", retry));
      auto encoded = coded_result(*results, id, format, coding, output->mesh);
      if (!encoded.ok()) return done(status_error_reply(encoded.error(), "/mesh"));
      done(mesh_reply(id, format, coding, std::move(encoded->bytes), output->from_cache, "/mesh"));
    };
  } else {
    owner_token = new_owner_token();
    how.holder = job_holder{token_digest(owner_token)};
  }
  const std::shared_ptr<const job_input> shared_input = std::move(input);
  submit_result submitted{submit_outcome::shutting_down, {}};
  if (upload->route == route_id::mesh) {
    submitted = deps_.jobs.submit(id, shared_input, std::move(listener), how);
  } else {
    // Accepted work is durable: the coordinator records the job (record + input) before it runs and before the
    // client hears 202.
    accept_result accepted = deps_.coordinator.accept(id, shared_input, how.holder->owner_hash);
    if (!accepted.error.ok()) {
      log_event(deps_.log, spdlog::level::err, "job_store_write_failed",
                {{"job", id}, {"error", accepted.error.message()}});
      return upload->done(with_retry_after(
          error_reply(503, "unavailable", "the job could not be stored; retry later", route),
          deps_.config.limits.retry_after_seconds));
    }
    submitted = {accepted.outcome, std::move(accepted.snapshot)};
  }
  const unsigned retry = deps_.config.limits.retry_after_seconds;
  log_event(deps_.log, spdlog::level::info, "job_submitted",
            {{"job", id},
             {"route", route},
             {"bytes", upload_bytes},
             {"atoms", atoms},
             {"parameters", proto::canonical_parameters(upload->request.params)},
             {"outcome", submitted.outcome == submit_outcome::accepted    ? "accepted"
                         : submitted.outcome == submit_outcome::coalesced ? "coalesced"
                         : submitted.outcome == submit_outcome::queue_full ? "queue_full"
                                                                            : "shutting_down"},
             {"prep_ms", std::chrono::duration<double, std::milli>(clock::now() - upload->received).count()}});
  switch (submitted.outcome) {
    case submit_outcome::queue_full:
      return upload->done(with_retry_after(
          error_reply(429, "queue_full", "the job queue is full; retry later", route), retry));
    case submit_outcome::shutting_down:
      return upload->done(
          with_retry_after(error_reply(503, "unavailable", "the server is shutting down", route), retry));
    case submit_outcome::accepted:
    case submit_outcome::coalesced: break;
  }
  if (upload->route == route_id::mesh) return;  // the listener answers
  deps_.jobs.subscribe(id, [client_job](const job_snapshot&, const job_output*) {});  // holds it until the end
  nlohmann::json accepted = {{"id", id},
                             {"status", std::string(proto::job_state_name(submitted.snapshot.state))},
                             {"token", owner_token},
                             {"links", job_links(id, upload->request.format)}};
  reply r = json_reply(202, accepted.dump(), route);
  r.headers.emplace_back("Location", "/jobs/" + id);
  r.headers.emplace_back(job_token_header, owner_token);
  upload->done(std::move(r));
}

// ---- job routes ---------------------------------------------------------------------------------------------

void api_handlers::log_result_lost(const std::string& id, proto::mesh_format format, const std::string& reason) {
  log_event(deps_.log, spdlog::level::err, "job_result_lost",
            {{"job", id}, {"key", mesh_key(id, format)}, {"reason", reason}});
}

void api_handlers::off_io_thread_if_blocking(std::function<void()> lookup) {
  if (!deps_.coordinator.blocking_lookups()) return lookup();
  boost::asio::post(deps_.prep, std::move(lookup));
}

void api_handlers::job_status(const std::string& id, reply_sink done) {
  off_io_thread_if_blocking([this, id, done = std::move(done)] {
    const result<std::optional<job_snapshot>> job = deps_.coordinator.find(id);
    if (!job.ok()) return done(records_unreachable_reply(job.error(), "/jobs/{id}"));
    if (*job) return done(json_reply(200, job_document(**job), "/jobs/{id}"));
    done(error_reply(404, "not_found", "no such job", "/jobs/{id}"));
  });
}

reply api_handlers::records_unreachable_reply(const status& error, std::string route) const {
  log_event(deps_.log, spdlog::level::err, "job_records_unreachable", {{"error", error.message()}});
  return with_retry_after(error_reply(503, "unavailable", "the job records cannot be read now; retry later",
                                      std::move(route)),
                          deps_.config.limits.retry_after_seconds);
}

void api_handlers::log_client_refusal(const std::string& client, std::string_view limit_name,
                                      std::string_view route) {
  std::uint64_t suppressed = 0;
  if (!refusal_log_.admit(client, std::chrono::steady_clock::now(), suppressed)) return;
  log_event(deps_.log, spdlog::level::warn, "client_limit_refused",
            {{"client", client},
             {"limit", limit_name},
             {"route", route},
             {"suppressed_before", suppressed}});
}

void api_handlers::job_events(const std::string& id, const std::string& client, reply_sink done) {
  off_io_thread_if_blocking([this, id, client, done = std::move(done)] {
    const std::string route = "/jobs/{id}/events";
    if (!deps_.coordinator.find_in_memory(id)) {
      const result<std::optional<job_snapshot>> job = deps_.coordinator.find(id);
      if (!job.ok()) return done(records_unreachable_reply(job.error(), route));
      if (!*job) return done(error_reply(404, "not_found", "no such job", route));
    }
    const server_limits& limits = deps_.config.limits;
    std::shared_ptr<client_lease> client_stream = client_event_streams_.acquire(client);
    if (!client_stream) {
      log_client_refusal(client, "max_event_streams_per_client", route);
      return done(client_limit_reply("max_event_streams_per_client", limits.max_event_streams_per_client,
                                     "event streams open", limits.retry_after_seconds, route));
    }
    if (deps_.state.event_streams.fetch_add(1, std::memory_order_relaxed) >= limits.max_event_streams) {
      deps_.state.event_streams.fetch_sub(1, std::memory_order_relaxed);
      return done(with_retry_after(error_reply(503, "unavailable",
                                               "too many event streams (" +
                                                   std::to_string(limits.max_event_streams) + "); poll GET /jobs/" +
                                                   id + " instead",
                                               route),
                                   limits.retry_after_seconds));
    }
    auto source = std::make_shared<job_event_source>(deps_.coordinator, deps_.prep, id,
                                                     std::make_unique<event_stream_slot>(
                                                         deps_.state.event_streams, std::move(client_stream)),
                                                     limits.replicas.event_fallback);
    reply r;
    r.route = route;
    r.content_type = "text/event-stream";
    r.events = std::move(source);
    done(std::move(r));
  });
}

void api_handlers::cancel_job(const std::string& id, const std::string& owner_token, reply_sink done) {
  const std::string route = "/jobs/{id}";
  if (owner_token.empty()) {
    return done(error_reply(401, "unauthorized",
                            "cancelling a job needs the X-Job-Token header returned when it was submitted", route));
  }
  off_io_thread_if_blocking([this, id, route, owner = token_digest(owner_token), done = std::move(done)] {
    const withdraw_result withdrawn = deps_.coordinator.withdraw(id, owner);
    if (!withdrawn.error.ok()) return done(records_unreachable_reply(withdrawn.error, route));
    const std::optional<job_snapshot>& job = withdrawn.job;
    if (withdrawn.outcome == cancel_outcome::not_found || withdrawn.outcome == cancel_outcome::already_final) {
      // A finished job changes for nobody: cancelled again is 200 (idempotent), done or failed 409, whoever asks
      // (GET tells the same).
      if (!job) return done(error_reply(404, "not_found", "no such job", route));
      if (job->state == job_state::cancelled) return done(json_reply(200, job_document(*job), route));
      return done(already_finished_reply(job->state, route));
    }
    if (withdrawn.outcome == cancel_outcome::not_owner) {
      return done(error_reply(403, "forbidden", "this token does not own the job", route));
    }
    log_event(deps_.log, spdlog::level::info, "job_cancel",
              {{"job", id},
               {"outcome", withdrawn.outcome == cancel_outcome::withdrawn ? "withdrawn" : "cancelled"},
               {"status", job ? std::string(proto::job_state_name(job->state)) : "unknown"}});
    if (!job) return done(error_reply(404, "not_found", "no such job", route));
    // cancelled; running until the pipeline sees the token; or, when other owners hold it, going on for them.
    done(json_reply(200, job_document(*job), route));
  });
}

std::optional<reply> api_handlers::authorization_failure(const request_head& head, const char* route) const {
  if (!deps_.auth.enabled()) return std::nullopt;
  const auto& exempt = deps_.config.auth_exempt_routes;
  if (std::find(exempt.begin(), exempt.end(), route) != exempt.end()) return std::nullopt;
  if (deps_.auth.accepts(to_std(head[http::field::authorization]))) return std::nullopt;
  reply r = error_reply(401, "unauthorized", "this server needs an Authorization: Bearer token", route);
  r.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"tracemeshd\"");
  return r;
}

void api_handlers::job_mesh(const request_head& head, const std::string& id,
                            std::optional<proto::mesh_format> requested, reply_sink done) {
  if (requested) return job_mesh_in(head, id, *requested, true, std::nullopt, std::move(done));
  // Without ?format: the format of the job's first submission (the one links.mesh names), from the queue while it
  // holds the job, else from the job's record (after a restart, or with Redis on another replica); OFF when
  // neither knows the job (the store's mesh may outlive its record).
  if (std::optional<job_snapshot> job = deps_.jobs.find(id)) {
    const proto::mesh_format format = job->format;
    return job_mesh_in(head, id, format, false, std::move(job), std::move(done));
  }
  off_io_thread_if_blocking([this, head, id, done = std::move(done)]() mutable {
    const result<std::optional<job_snapshot>> record = deps_.coordinator.find(id);
    if (!record.ok()) return done(records_unreachable_reply(record.error(), "/jobs/{id}/mesh"));
    const proto::mesh_format format = *record ? (*record)->format : proto::mesh_format::off;
    job_mesh_in(head, id, format, false, *record, std::move(done));
  });
}

void api_handlers::job_mesh_in(const request_head& head, const std::string& id, proto::mesh_format format,
                               bool requested, std::optional<job_snapshot> job, reply_sink done) {
  const std::string route = "/jobs/{id}/mesh";
  // Only a URL naming its format always names the same bytes.
  const bool immutable = requested;
  const std::optional<content_coding> coding = mesh_coding(accept_encoding(head), format);
  if (!coding) return done(not_acceptable_reply(format, route));
  const std::string etag = etag_for(id, format, *coding);
  const bool if_match_failed = if_match_fails(head, etag);
  const bool if_none_match = etag_matches(head, etag);
  // The whole answer once the bytes are known: 412 (If-Match goes first, RFC 9110 §13.2.2), 304, or the bytes
  // (a range of them, 416) with their headers.
  auto answer = [id, format, coding = *coding, etag, if_match_failed, if_none_match, immutable, route,
                 head_copy = head](std::shared_ptr<const std::string> bytes, bool cache_hit) {
    if (if_match_failed) return precondition_failed_reply(etag, route);
    if (if_none_match) return not_modified(id, format, coding, route);
    return with_range(mesh_reply(id, format, coding, std::move(bytes), cache_hit, route, immutable), head_copy, etag);
  };
  // The hot path: a memory hit is answered from the I/O thread, no hop.
  if (auto bytes = deps_.cache.get_from_memory(coded_mesh_key(id, format, *coding))) {
    deps_.stats.count_cache_response();
    return done(answer(std::move(bytes), true));
  }
  if (requested) job = deps_.jobs.find(id);
  if (job && job->state != job_state::done) {
    const std::string message =
        job->state == job_state::queued || job->state == job_state::running
            ? "the job is " + std::string(proto::job_state_name(job->state)) + "; poll /jobs/" + id
            : "the job " + std::string(proto::job_state_name(job->state)) + ": " + job->error.message();
    return done(error_reply(409, "conflict", message, route));
  }
  // The cached encoding, else the job store's mesh encoded now (and cached): a done job within retention always
  // has every format, whatever the cache evicted or lost. A format the report says refused this mesh gets that
  // reason (413 for that format only; the others are served).
  boost::asio::post(deps_.prep, [this, id, format, coding = *coding, route, answer = std::move(answer),
                                  done = std::move(done)] {
    auto encoded = coded_result(deps_.results, id, format, coding);
    if (encoded.ok()) {
      if (encoded->cache_hit) deps_.stats.count_cache_response();
      return done(answer(std::move(encoded->bytes), encoded->cache_hit));
    }
    if (encoded.error().code() == errc::io_error) {
      log_result_lost(id, format, encoded.error().message());
      return done(error_reply(404, "not_found", "the result of this job was lost; submit it again", route));
    }
    if (encoded.error().code() != errc::invalid_argument) return done(status_error_reply(encoded.error(), route));
    done(error_reply(404, "not_found", "no mesh for this job", route));
  });
}

// ---- health and metrics -------------------------------------------------------------------------------------

reply api_handlers::readiness_reply() const {
  if (deps_.state.draining.load()) {
    return error_reply(503, "unavailable", "the server is shutting down", "/readyz");
  }
  if (deps_.jobs.queue_depth() >= deps_.config.limits.max_queue) {
    return with_retry_after(error_reply(503, "unavailable", "the job queue is full", "/readyz"),
                            deps_.config.limits.retry_after_seconds);
  }
  if (const std::optional<std::string> why = deps_.coordinator.unready_reason()) {
    return with_retry_after(error_reply(503, "unavailable", *why, "/readyz"), deps_.config.limits.retry_after_seconds);
  }
  if (!deps_.coordinator.durable()) {
    return json_reply(200,
                      R"({"status":"ready","durable":false,"warning":"no disk store: accepted jobs and results )"
                      R"(are kept in memory only and a restart loses them"})",
                      "/readyz");
  }
  return json_reply(200, R"({"status":"ready","durable":true})", "/readyz");
}

reply api_handlers::metrics_reply() const {
  metrics_gauges gauges;
  gauges.queue_depth = deps_.jobs.queue_depth();
  gauges.running_jobs = deps_.jobs.running_jobs();
  gauges.open_connections = deps_.state.open_connections.load();
  const cache_stats cache = deps_.cache.stats();
  gauges.cache_hits = cache.hits;
  gauges.cache_misses = cache.misses;
  gauges.cache_memory_bytes = cache.memory_bytes;
  gauges.cache_disk_bytes = cache.disk_bytes;
  gauges.cache_entries = cache.entries;
  gauges.cache_corrupt_entries = cache.corrupt_entries;
  gauges.cache_evictions = cache.evictions;
  gauges.cache_write_failures = cache.write_failures;
  deps_.coordinator.add_gauges(gauges);
  reply r;
  r.route = "/metrics";
  r.content_type = "text/plain; version=0.0.4; charset=utf-8";
  r.body = std::make_shared<const std::string>(deps_.stats.render(gauges));
  return r;
}

}  // namespace tracemesh::server
