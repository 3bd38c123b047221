// Fuzz target for tracemeshd's HTTP request handling (service-test-list item 54): whole request bytes into one
// connection (server/http/detail/http_session.hpp) over a Beast test stream, with the real request planning, API
// handlers, job queue and memory cache behind it and a fake mesher (a tetrahedron, at once).
//
// Input: the first byte picks how many bytes each read of the server returns (1..256, so the HTTP and multipart
// parsers see every split); the rest is everything the client sends before closing its side.
// Checks: the connection ends (no hang), and what the server wrote is a sequence of well-formed HTTP/1.1
// responses: known status codes, framed by Content-Length (none for 204/304, no body for HEAD), nothing after a
// "Connection: close", every error a JSON {"error":{"code","message"}} body, at most one final response per planned
// request, and every response to a request refused before planning (no route: a malformed or oversized header, a
// bad Transfer-Encoding, a missing Host) a 400/431/503 that ends the connection, except the missing-Host 400 of a
// request without a body, which may keep it (the server read that request whole).
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/beast/_experimental/test/stream.hpp>
#include <boost/beast/http.hpp>
#include <nlohmann/json.hpp>

#include "server/api/api_handlers.hpp"
#include "server/jobs/local_job_coordinator.hpp"
#include "server/http/detail/http_session.hpp"
#include "server/jobs/job_queue.hpp"
#include "server/observability/logging.hpp"
#include "server/jobs/mesh_job.hpp"
#include "server/storage/result_cache.hpp"

namespace tracemesh::server::detail {

/// The test stream has no timers (a fuzz input cannot wait for a deadline) and closes both directions at once.
template <>
struct stream_transport<boost::beast::test::stream> {
  static void expire_after(boost::beast::test::stream&, std::chrono::steady_clock::duration) {}
  static void expire_at(boost::beast::test::stream&, std::chrono::steady_clock::time_point) {}
  static void expire_never(boost::beast::test::stream&) {}
  static void cancel(boost::beast::test::stream& s) { s.close(); }
  static void close(boost::beast::test::stream& s) { s.close(); }
  static void shutdown_send(boost::beast::test::stream& s) { s.close(); }
  static std::string client_address(boost::beast::test::stream&) { return "test-stream"; }
  static bool has_unread_bytes(boost::beast::test::stream&) { return false; }
};

}  // namespace tracemesh::server::detail

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using namespace tracemesh;
using namespace tracemesh::server;

/// Longest a single input may keep the connection open before the harness calls it a hang.
constexpr std::chrono::seconds hang_limit{20};

void require(bool condition, const char* what, std::string_view context = {}) {
  if (condition) return;
  std::fprintf(stderr, "http_request_fuzzer: %s\n%.*s\n", what, static_cast<int>(context.size()), context.data());
  std::abort();
}

result<mesh_output> tetrahedron(const molecule&, const mesh_params&, const mesh_limits&, progress_token& token) {
  if (!token.report(mesh_stage::sampling, 0.5)) return status(errc::cancelled, "cancelled");
  mesh_output out;
  out.mesh.positions = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  out.mesh.triangles = {{{0, 1, 2}}, {{0, 3, 1}}, {{0, 2, 3}}, {{1, 3, 2}}};
  out.report.vertices = 4;
  out.report.triangles = 4;
  out.certified = true;
  return out;
}

/// Small limits, so that short inputs reach every limit.
server_config fuzz_config() {
  server_config config;
  config.workers = 1;
  config.limits.max_upload_bytes = 64 * 1024;
  config.limits.max_upload_bytes_in_flight = 128 * 1024;
  config.limits.max_pqr_bytes = 256 * 1024;
  config.limits.max_small_body_bytes = 1024;
  config.limits.max_header_bytes = 2048;
  config.limits.max_form_parts = 6;
  config.limits.max_form_field_bytes = 64;
  config.limits.max_queue = 2;
  config.limits.mesh.max_atoms = 200;
  config.limits.job_timeout = std::chrono::seconds(10);
  // The rate check's timer would keep each input's io_context running for the grace time; its deadlines are
  // no-ops over the test stream anyway.
  config.limits.min_upload_bytes_per_second = 0;
  return config;
}

/// A request the server planned: its method, and where in the server's output its response starts (the server
/// reads the next request only once the previous response is written, so that is the output's size at planning).
struct planned_request {
  std::size_t response_offset;
  http::verb method;
};

/// Remembers every request the server planned, in order, with the offset of its response.
class recording_handler final : public request_handler {
 public:
  explicit recording_handler(request_handler& inner) : inner_(inner) {}
  /// How many bytes the server has written so far (set by serve() for its connection).
  std::function<std::size_t()> output_size;
  std::variant<reply, body_plan> plan(const request_head& head, const std::string& client) override {
    std::lock_guard lock(mutex_);
    planned_.push_back({output_size ? output_size() : 0, head.method()});
    return inner_.plan(head, client);
  }
  void handle(const request_head& head, const body_plan& plan, std::string body, reply_sink done) override {
    inner_.handle(head, plan, std::move(body), std::move(done));
  }
  void handle_upload(const request_head& head, body_plan plan, std::vector<multipart_part> parts,
                     reply_sink done) override {
    inner_.handle_upload(head, std::move(plan), std::move(parts), std::move(done));
  }
  void handle_encoded_upload(const request_head& head, body_plan plan, std::string body, reply_sink done) override {
    inner_.handle_encoded_upload(head, std::move(plan), std::move(body), std::move(done));
  }
  bool is_health_route(std::string_view target) const override { return inner_.is_health_route(target); }
  std::vector<planned_request> planned() const {
    std::lock_guard lock(mutex_);
    return planned_;
  }

 private:
  request_handler& inner_;
  mutable std::mutex mutex_;
  std::vector<planned_request> planned_;
};

/// The service's parts as service.cpp wires them, without the listener (fresh per input: no state carries over).
struct fuzz_service {
  server_config config = fuzz_config();
  std::shared_ptr<spdlog::logger> log = make_null_logger();
  metrics stats;
  http_server_state state;
  cors_policy cors{{"*"}};
  result_cache cache{{}, cache_limits{1u << 20, 0}};
  job_store store{job_store_options{{}, std::chrono::hours(1), 1u << 20}};
  bearer_tokens auth;
  mesh_job_context mesh_context{cache, store, stats, *log, config.limits.mesh, 1, tetrahedron};
  job_queue jobs{job_queue_options{1, config.limits.max_queue, 64, config.limits.job_timeout},
                 [this](const std::string& id, const job_input& input, progress_token& token) {
                   return run_mesh_job(mesh_context, id, input, token);
                 },
                 stats};
  local_job_coordinator coordinator{jobs, store};
  net::thread_pool prep{1};
  net::thread_pool large_uploads{1};
  api_handlers api{api_dependencies{config, jobs, cache, coordinator, mesh_context, auth, stats, *log, state, cors, prep,
                                    large_uploads}};
  recording_handler recorder{api};
  http_context context{config.limits, recorder, state, stats, *log, cors};

  ~fuzz_service() {
    jobs.shutdown(std::chrono::milliseconds(0));
    large_uploads.join();
    prep.join();
  }
};

/// Runs one connection fed `input` (then EOF) with reads of at most `read_size` bytes; what the server wrote.
std::string serve(fuzz_service& service, std::string_view input, std::size_t read_size) {
  net::io_context io;
  beast::test::stream server_side(io);
  beast::test::stream client_side(io);
  server_side.connect(client_side);
  service.recorder.output_size = [&client_side] { return client_side.str().size(); };
  server_side.read_size(read_size);
  server_side.append(beast::string_view(input.data(), input.size()));
  server_side.close_remote();  // the client sent everything it will send
  std::make_shared<detail::http_session<beast::test::stream>>(std::move(server_side), service.context)->run();
  auto work = net::make_work_guard(io);  // replies arrive from the prep pool and the job worker
  const auto give_up = std::chrono::steady_clock::now() + hang_limit;
  while (service.state.open_connections.load() > 0) {
    io.run_one_for(std::chrono::milliseconds(5));
    require(std::chrono::steady_clock::now() < give_up, "the connection did not end", input);
  }
  work.reset();
  io.poll();
  service.recorder.output_size = nullptr;
  return std::string(client_side.str());
}

const std::set<unsigned> known_statuses{100, 200, 202, 204, 304, 400, 401, 403, 404, 405, 408, 409,
                                        412, 413, 415, 422, 429, 431, 500, 503, 504};

void check_error_body(const std::string& body, std::string_view context) {
  const nlohmann::json doc = nlohmann::json::parse(body, nullptr, false);
  require(!doc.is_discarded() && doc.is_object() && doc.contains("error"), "error body is not JSON", context);
  const nlohmann::json& error = doc["error"];
  require(error.contains("code") && error["code"].is_string() && !error["code"].get<std::string>().empty(),
          "error body without a code", context);
  require(error.contains("message") && error["message"].is_string(), "error body without a message", context);
}

constexpr std::string_view missing_host_message = "an HTTP/1.1 request must carry exactly one Host header field";

/// Whether the response at the start of `output` carries its body: its header parsed alone, then a body follows
/// unless Content-Length is 0 or what follows is the next response (or nothing). Only for responses to requests
/// refused before planning, whose method the harness does not know (the answer to HEAD has no body); their bodies
/// are JSON error objects, so they start with '{' and never with "HTTP/".
bool unplanned_response_has_body(std::string_view output, std::string_view input) {
  http::response_parser<http::empty_body> header;
  header.eager(false);
  beast::error_code ec;
  const std::size_t used = header.put(net::buffer(output.data(), output.size()), ec);
  require((!ec || ec == http::error::need_buffer) && header.is_header_done(), "malformed response header", input);
  const std::string_view rest = output.substr(used);
  return header.content_length().value_or(0) > 0 && !rest.empty() && rest.substr(0, 5) != "HTTP/";
}

/// Parses the server's output as consecutive responses; `planned` are the planned requests, in order.
void check_responses(std::string_view output, const std::vector<planned_request>& planned, std::string_view input) {
  const std::size_t total = output.size();
  std::size_t next_planned = 0;
  const planned_request* current = nullptr;  // the planned request being answered (after a 100 Continue too)
  bool closed = false;
  while (!output.empty()) {
    require(!closed, "bytes after a Connection: close response", input);
    const std::size_t offset = total - output.size();
    if (current == nullptr && next_planned < planned.size() && planned[next_planned].response_offset == offset) {
      current = &planned[next_planned++];
    }
    require(next_planned >= planned.size() || planned[next_planned].response_offset > offset,
            "a planned request without its response", input);
    const bool head_request =
        current != nullptr ? current->method == http::verb::head : !unplanned_response_has_body(output, input);
    http::response_parser<http::string_body> parser;
    parser.eager(true);
    parser.body_limit(16u << 20);
    parser.skip(head_request);  // the answer to HEAD announces a length but carries no body
    beast::error_code ec;
    const std::size_t used = parser.put(net::buffer(output.data(), output.size()), ec);
    require(!ec && parser.is_done(), "malformed or truncated response", input);
    output.remove_prefix(used);
    const auto& response = parser.get();
    const unsigned code = response.result_int();
    require(known_statuses.count(code) == 1, "unexpected status code", input);
    if (code == 100) {
      require(current != nullptr, "100 Continue to a request that was not planned", input);
      continue;
    }
    if (code != 204 && code != 304) require(response.has_content_length(), "no Content-Length", input);
    if (code >= 400 && !head_request) check_error_body(response.body(), input);
    closed = !parser.keep_alive();
    if (current == nullptr) {
      // Refused before planning: a malformed or oversized header, a bad Transfer-Encoding, the health-only mode or
      // a missing Host. Only the missing-Host refusal of a request without a body keeps the connection.
      require(code == 400 || code == 431 || code == 503, "unexpected status for an unplanned request", input);
      if (!closed) {
        require(code == 400, "an unplanned refusal other than a missing Host kept the connection", input);
        if (!head_request) {
          const nlohmann::json doc = nlohmann::json::parse(response.body(), nullptr, false);
          require(doc.at("error").at("message").get<std::string>() == missing_host_message,
                  "an unplanned refusal other than a missing Host kept the connection", input);
        }
      }
    }
    current = nullptr;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::size_t read_size = std::size_t{data[0]} + 1;
  const std::string_view input(reinterpret_cast<const char*>(data + 1), size - 1);
  fuzz_service service;
  const std::string output = serve(service, input, read_size);
  check_responses(output, service.recorder.planned(), input);
  return 0;
}
