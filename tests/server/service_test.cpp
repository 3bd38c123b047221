// Tests of server/service.hpp (and through it http_server.hpp, api_handlers.hpp, mesh_job.hpp, cors.hpp): a real
// service on a loopback port with a fake mesher behind a gate, talked to over raw sockets. Covers HTTP framing and
// limits, slow clients, the API's errors, single-flight, back-pressure, cancellation, timeouts and shutdown
// (service-test-list A, B, E, G, J). The real mesher and curl are exercised in tests/integration/.
#include "server/service.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include "server/content_hash.hpp"
#include "server/logging.hpp"
#include "server/test_http_client.hpp"
#include "support/test_paths.hpp"

namespace tracemesh::server {
namespace {

using namespace std::chrono_literals;
using testing::round_trip;
using testing::get_request;
using testing::http_reply;
using testing::raw_connection;
using testing::upload_request;

/// Stands in for mesh_molecule: a tetrahedron, after a gate the test may hold closed (polling the token).
class fake_mesher {
 public:
  mesher_function function() {
    return [this](const molecule& mol, const mesh_params&, const mesh_limits&,
                  progress_token& token) -> result<mesh_output> {
      runs_.fetch_add(1);
      std::unique_lock lock(mutex_);
      while (!open_) {
        if (!token.report(mesh_stage::sampling, 0.25)) return status(errc::cancelled, "cancelled");
        changed_.wait_for(lock, 2ms);
      }
      mesh_output out;
      const double r = mol.atoms.empty() ? 1.0 : mol.atoms.front().radius;
      out.mesh.positions = {{r, r, r}, {r, -r, -r}, {-r, r, -r}, {-r, -r, r}};
      out.mesh.triangles = {{{0, 1, 2}}, {{0, 3, 1}}, {{0, 2, 3}}, {{1, 3, 2}}};
      out.report.vertices = 4;
      out.report.triangles = 4;
      out.atoms_meshed = mol.atoms.size();
      out.certified = true;
      return out;
    };
  }
  void set_open(bool open) {
    std::lock_guard lock(mutex_);
    open_ = open;
    changed_.notify_all();
  }
  int runs() const { return runs_.load(); }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = true;
  std::atomic<int> runs_{0};
};

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string atom_line(int serial, double x, double radius = 1.5) {
  std::ostringstream line;
  line << "ATOM " << serial << " C ALA 1 " << x << " 0.0 0.0 0.0 " << radius << "\n";
  return line.str();
}

class ServiceTest : public ::testing::Test {
 protected:
  void start(const std::function<void(server_config&)>& adjust = {}) {
    config_.listen_port = 0;
    config_.workers = 1;
    config_.limits.max_upload_bytes = 256 * 1024;
    config_.limits.max_queue = 4;
    config_.limits.header_timeout = 2s;
    config_.limits.request_timeout = 3s;
    config_.limits.write_timeout = 3s;
    config_.limits.shutdown_grace = 200ms;
    config_.limits.job_timeout = 10s;
    if (adjust) adjust(config_);
    service_ = std::make_unique<service>(config_, make_null_logger(), mesher_.function());
    const status started = service_->start();
    ASSERT_TRUE(started.ok()) << started.message();
    port_ = service_->port();
  }
  void TearDown() override {
    mesher_.set_open(true);
    if (service_) service_->shutdown();
  }

  http_reply post(const std::string& target, const std::string& pqr,
                  const std::vector<std::pair<std::string, std::string>>& fields = {}) {
    return round_trip(port_, upload_request(target, pqr, fields));
  }
  http_reply get(const std::string& target, const std::string& headers = {}) {
    return round_trip(port_, get_request(target, headers));
  }
  /// Polls GET /jobs/{id} until the job is final.
  nlohmann::json wait_job(const std::string& id) {
    for (int i = 0; i < 500; ++i) {
      const http_reply r = get("/jobs/" + id);
      if (r.status != 200) return nlohmann::json{{"http", r.status}};
      const auto doc = nlohmann::json::parse(r.body);
      const std::string state = doc.at("status");
      if (state == "done" || state == "failed" || state == "cancelled") return doc;
      std::this_thread::sleep_for(10ms);
    }
    return nlohmann::json{{"timeout", true}};
  }
  void expect_error(const http_reply& r, int status, const std::string& code) {
    EXPECT_EQ(r.status, status) << r.body;
    if (r.status == 0) return;
    const auto doc = nlohmann::json::parse(r.body, nullptr, false);
    ASSERT_FALSE(doc.is_discarded()) << r.body;
    EXPECT_EQ(doc["error"]["code"], code) << r.body;
    EXPECT_FALSE(doc["error"]["message"].get<std::string>().empty());
  }

  const std::string gly_ = read_file(tracemesh::testing::molecule_path("gly.pqr"));
  fake_mesher mesher_;
  server_config config_;
  std::unique_ptr<service> service_;
  unsigned short port_ = 0;
};

TEST_F(ServiceTest, MeshesSynchronouslyThenServesTheCachedResult) {
  start();
  const http_reply first = post("/mesh", gly_);
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(first.body.rfind("OFF\n4 4 0\n", 0), 0u) << first.body;
  EXPECT_EQ(first.header("x-cache"), "miss");
  const std::string id = first.header("x-job-id");
  EXPECT_TRUE(is_valid_job_id(id)) << id;
  EXPECT_EQ(first.header("content-disposition"), "attachment; filename=\"" + id.substr(0, 12) + ".off\"");
  EXPECT_EQ(first.header("content-type"), "model/vnd.off");
  EXPECT_FALSE(first.header("etag").empty());
  EXPECT_EQ(first.header("access-control-allow-origin"), "*");

  const http_reply second = post("/mesh", gly_);
  ASSERT_EQ(second.status, 200);
  EXPECT_EQ(second.header("x-cache"), "hit");
  EXPECT_EQ(second.body, first.body);
  EXPECT_EQ(second.header("etag"), first.header("etag"));
  EXPECT_EQ(mesher_.runs(), 1);

  const http_reply draco = get("/jobs/" + id + "/mesh?format=draco");
  ASSERT_EQ(draco.status, 200);
  EXPECT_EQ(draco.body.substr(0, 5), "DRACO");
  EXPECT_EQ(draco.header("content-type"), "application/vnd.google.draco");
  const http_reply unchanged = get("/jobs/" + id + "/mesh?format=draco", "If-None-Match: " + draco.header("etag") +
                                                                          "\r\n");
  EXPECT_EQ(unchanged.status, 304);
  EXPECT_TRUE(unchanged.body.empty());
  EXPECT_EQ(mesher_.runs(), 1);
}

TEST_F(ServiceTest, AsynchronousJobsReportStatusAndKeepTheirId) {
  start();
  mesher_.set_open(false);
  const http_reply accepted = post("/jobs", gly_, {{"density", "2"}, {"format", "draco"}});
  ASSERT_EQ(accepted.status, 202) << accepted.body;
  const auto doc = nlohmann::json::parse(accepted.body);
  const std::string id = doc.at("id");
  EXPECT_TRUE(is_valid_job_id(id));
  EXPECT_EQ(doc.at("links").at("self"), "/jobs/" + id);
  EXPECT_EQ(accepted.header("location"), "/jobs/" + id);

  const http_reply pending = get("/jobs/" + id + "/mesh");
  expect_error(pending, 409, "conflict");
  const auto running = nlohmann::json::parse(get("/jobs/" + id).body);
  EXPECT_TRUE(running.at("status") == "queued" || running.at("status") == "running") << running;
  mesher_.set_open(true);
  const auto done = wait_job(id);
  EXPECT_EQ(done.at("status"), "done") << done;
  EXPECT_EQ(done.at("progress"), 1.0);
  EXPECT_EQ(done.at("report").at("vertices"), 4);
  EXPECT_TRUE(done.at("error").is_null());

  // "2" and "2.0" are the same parameter: same id, already done.
  const http_reply again = post("/jobs?density=2.0", gly_);
  ASSERT_EQ(again.status, 200) << again.body;
  EXPECT_EQ(nlohmann::json::parse(again.body).at("id"), id);
  EXPECT_EQ(nlohmann::json::parse(again.body).at("status"), "done");
  EXPECT_EQ(mesher_.runs(), 1);
  EXPECT_EQ(get("/jobs/" + id + "/mesh").status, 200);
}

TEST_F(ServiceTest, IdenticalConcurrentUploadsRunTheMesherOnce) {
  start([](server_config& c) { c.io_threads = 2; });
  mesher_.set_open(false);
  constexpr int clients = 20;
  std::vector<http_reply> replies(clients);
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) threads.emplace_back([&, i] { replies[i] = post("/mesh", gly_); });
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (mesher_.runs() == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  std::this_thread::sleep_for(200ms);  // let the other uploads join the running job
  mesher_.set_open(true);
  for (auto& t : threads) t.join();
  for (const auto& r : replies) {
    ASSERT_EQ(r.status, 200) << r.body;
    EXPECT_EQ(r.body, replies[0].body);
    EXPECT_EQ(r.header("x-job-id"), replies[0].header("x-job-id"));
  }
  EXPECT_EQ(mesher_.runs(), 1);
  EXPECT_EQ(service_->stats().mesher_runs(), 1u);
}

TEST_F(ServiceTest, FullQueueAnswers429WithRetryAfterAndRecovers) {
  start([](server_config& c) { c.limits.max_queue = 1; });
  mesher_.set_open(false);
  ASSERT_EQ(post("/jobs", atom_line(1, 0.0)).status, 202);  // runs
  const auto wait_deadline = std::chrono::steady_clock::now() + 5s;
  while (mesher_.runs() == 0 && std::chrono::steady_clock::now() < wait_deadline) std::this_thread::sleep_for(1ms);
  ASSERT_EQ(post("/jobs", atom_line(1, 1.0)).status, 202);  // waits
  const http_reply refused = post("/jobs", atom_line(1, 2.0));
  expect_error(refused, 429, "queue_full");
  EXPECT_EQ(refused.header("retry-after"), "5");
  expect_error(get("/readyz"), 503, "unavailable");
  EXPECT_EQ(get("/healthz").status, 200);
  mesher_.set_open(true);
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (get("/readyz").status != 200 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_EQ(post("/jobs", atom_line(1, 2.0)).status, 202);
}

TEST_F(ServiceTest, ConcurrentUploadsBeyondTheLimitGet429) {
  start([](server_config& c) { c.limits.max_concurrent_uploads = 1; });
  const std::string full = upload_request("/mesh", gly_);
  raw_connection holding(port_);
  ASSERT_TRUE(holding.send(full.substr(0, full.size() - 10)));  // an upload still being received
  std::this_thread::sleep_for(50ms);
  const http_reply refused = post("/mesh", gly_);
  expect_error(refused, 429, "queue_full");
  EXPECT_FALSE(refused.header("retry-after").empty());
  ASSERT_TRUE(holding.send(full.substr(full.size() - 10)));
  EXPECT_EQ(holding.read_reply().status, 200);
  EXPECT_EQ(post("/mesh", gly_).status, 200);  // the slot was released
}

TEST_F(ServiceTest, BadRequestsGetTheRightStatusAndTheServerKeepsServing) {
  start();
  expect_error(get("/nowhere"), 404, "not_found");
  const http_reply wrong_method = get("/mesh");
  expect_error(wrong_method, 405, "method_not_allowed");
  EXPECT_EQ(wrong_method.header("allow"), "POST, OPTIONS");
  expect_error(round_trip(port_, "GET http://test/healthz HTTP/1.1\r\nHost: test\r\n\r\n"), 400, "bad_request");
  expect_error(round_trip(port_, "BREW /healthz HTTP/1.1\r\nHost: test\r\n\r\n"), 405, "method_not_allowed");
  expect_error(round_trip(port_, "GET /healthz HTTP/1.1\r\nHost: test\r\nContent-Length: 1\r\n"
                                 "Transfer-Encoding: chunked\r\n\r\n0\r\n\r\n"),
               400, "bad_request");  // request smuggling hygiene
  expect_error(round_trip(port_, "POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\n"
                               "Content-Length: 2\r\n\r\n{}"),
               415, "unsupported_media_type");
  expect_error(round_trip(port_, "POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data\r\n"
                               "Content-Length: 2\r\n\r\nxx"),
               400, "invalid_input");
  const http_reply bad_line = post("/mesh", "ATOM 1 C ALA 1 1.0 2.0 nan 0.0 1.5\n");
  expect_error(bad_line, 400, "invalid_input");
  EXPECT_NE(bad_line.body.find("line 1"), std::string::npos) << bad_line.body;
  expect_error(post("/mesh", "REMARK nothing here\nEND\n"), 422, "nothing_to_mesh");
  expect_error(post("/mesh", gly_, {{"density", "abc"}}), 400, "invalid_argument");
  expect_error(post("/mesh", gly_, {{"density", "1e9"}}), 400, "invalid_argument");
  expect_error(post("/mesh", gly_, {{"format", "obj"}}), 400, "invalid_argument");
  expect_error(post("/mesh", gly_, {{"colour", "red"}}), 400, "invalid_argument");
  expect_error(post("/mesh?probe=1.4", gly_), 400, "invalid_argument");
  expect_error(post("/mesh", gly_, {{"pqr", "twice"}}), 400, "invalid_input");
  expect_error(round_trip(port_, "POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; boundary=b\r\n"
                               "Content-Length: 47\r\n\r\n--b\r\nContent-Disposition: form-data; name=\"d\"\r\n\r\n"),
               400, "invalid_input");  // truncated multipart body
  const std::string no_file = "--b\r\nContent-Disposition: form-data; name=\"density\"\r\n\r\n1\r\n--b--\r\n";
  expect_error(round_trip(port_, "POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; boundary=b\r\n"
                               "Content-Length: " + std::to_string(no_file.size()) + "\r\n\r\n" + no_file),
               400, "invalid_input");
  expect_error(get("/jobs/../../etc/passwd"), 404, "not_found");  // not a route at all
  for (const char* id : {"..%2f..%2fetc%2fpasswd", "%2e%2e%2f", "ABCDEF", "0123", "%00"}) {
    expect_error(get(std::string("/jobs/") + id), 400, "invalid_argument");
  }
  expect_error(get("/jobs/" + std::string(64, 'a')), 404, "not_found");
  expect_error(get("/jobs/" + std::string(64, 'a') + "/mesh"), 404, "not_found");
  expect_error(get("/jobs/" + std::string(64, 'a') + "/mesh?format=png"), 400, "invalid_argument");
  EXPECT_EQ(get("/healthz").status, 200);
  EXPECT_EQ(mesher_.runs(), 0);
}

TEST_F(ServiceTest, OversizedUploadsAre413BeforeTheBodyAndWithoutContinue) {
  start();
  raw_connection connection(port_);
  ASSERT_TRUE(connection.send("POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; boundary=b\r\n"
                              "Content-Length: 1000000000\r\nExpect: 100-continue\r\n\r\n"));
  const http_reply r = connection.read_reply();
  expect_error(r, 413, "limit_exceeded");
  EXPECT_EQ(r.header("connection"), "close");
  EXPECT_TRUE(connection.closed_by_peer(2s));

  // Chunked: no length up front, counted while streaming.
  raw_connection chunked(port_);
  ASSERT_TRUE(chunked.send("POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; boundary=b\r\n"
                           "Transfer-Encoding: chunked\r\n\r\n"));
  const std::string piece(64 * 1024, 'x');
  bool refused = false;
  for (int i = 0; i < 8 && !refused; ++i) {
    std::ostringstream chunk;
    chunk << std::hex << piece.size() << "\r\n" << piece << "\r\n";
    refused = !chunked.send(chunk.str());
  }
  expect_error(chunked.read_reply(), 413, "limit_exceeded");
  EXPECT_EQ(get("/healthz").status, 200);
}

TEST_F(ServiceTest, ExpectContinueIsAnsweredAfterTheHeaderIsAccepted) {
  start();
  const std::string full = upload_request("/mesh", gly_, {}, "Expect: 100-continue\r\n");
  const auto split = full.find("\r\n\r\n") + 4;
  raw_connection connection(port_);
  ASSERT_TRUE(connection.send(full.substr(0, split)));
  EXPECT_EQ(connection.read_reply().status, 100);
  ASSERT_TRUE(connection.send(full.substr(split)));
  const http_reply r = connection.read_reply();
  EXPECT_EQ(r.status, 200) << r.body;
}

TEST_F(ServiceTest, ChunkedUploadsAndTinyWritesParseTheSame) {
  start();
  const http_reply whole = post("/mesh", gly_);
  ASSERT_EQ(whole.status, 200);
  for (std::size_t chunk : {1u, 3u, 7u}) {
    raw_connection connection(port_);
    ASSERT_TRUE(connection.send_in_chunks(upload_request("/mesh", gly_), chunk, 20us));
    const http_reply r = connection.read_reply();
    EXPECT_EQ(r.status, 200) << "chunk " << chunk << ": " << r.body;
    EXPECT_EQ(r.header("x-job-id"), whole.header("x-job-id")) << chunk;
    EXPECT_EQ(r.body, whole.body);
  }
  const std::string boundary = "----tracemesh-test-boundary";
  const std::string body = testing::multipart_body(boundary, gly_);
  std::string request = "POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; boundary=" + boundary +
                        "\r\nTransfer-Encoding: chunked\r\n\r\n";
  for (std::size_t at = 0; at < body.size(); at += 100) {
    const std::string piece = body.substr(at, 100);
    std::ostringstream size;
    size << std::hex << piece.size();
    request += size.str() + "\r\n" + piece + "\r\n";
  }
  request += "0\r\n\r\n";
  const http_reply chunked = round_trip(port_, request);
  EXPECT_EQ(chunked.status, 200) << chunked.body;
  EXPECT_EQ(chunked.header("x-job-id"), whole.header("x-job-id"));
  EXPECT_EQ(mesher_.runs(), 1);
}

TEST_F(ServiceTest, HeaderLimitGives431AndClosesTheConnection) {
  start();
  const std::string big_header = "X-Filler: " + std::string(9000, 'a') + "\r\n";
  raw_connection connection(port_);
  ASSERT_TRUE(connection.send(get_request("/healthz", big_header)));
  const http_reply r = connection.read_reply();
  expect_error(r, 431, "header_too_large");
  EXPECT_TRUE(connection.closed_by_peer(2s));
  // Just under the limit is fine.
  EXPECT_EQ(get("/healthz", "X-Filler: " + std::string(7000, 'a') + "\r\n").status, 200);
}

TEST_F(ServiceTest, SlowClientsAreCutAtTheirDeadlinesWhileOthersAreServed) {
  start([](server_config& c) {
    c.limits.header_timeout = 300ms;
    c.limits.request_timeout = 600ms;
  });
  raw_connection slow_header(port_);
  ASSERT_TRUE(slow_header.send("GET /healthz HTTP/1.1\r\nHost: t\r\n"));  // never finished
  const std::string full = upload_request("/mesh", gly_);
  raw_connection slow_body(port_);
  ASSERT_TRUE(slow_body.send(full.substr(0, full.size() - 20)));  // body never finished
  EXPECT_EQ(get("/healthz").status, 200);
  const auto started = std::chrono::steady_clock::now();
  EXPECT_TRUE(slow_header.closed_by_peer(3s));
  EXPECT_TRUE(slow_body.closed_by_peer(3s));
  EXPECT_LT(std::chrono::steady_clock::now() - started, 2s);
  // An idle keep-alive connection is closed at the header timeout too.
  raw_connection idle(port_);
  ASSERT_TRUE(idle.send(get_request("/healthz")));
  EXPECT_EQ(idle.read_reply().status, 200);
  EXPECT_TRUE(idle.closed_by_peer(3s));
  EXPECT_EQ(mesher_.runs(), 0);
}

TEST_F(ServiceTest, KeepAliveServesSeveralRequestsInOrder) {
  start();
  raw_connection connection(port_);
  ASSERT_TRUE(connection.send(get_request("/healthz") + get_request("/readyz") + get_request("/nowhere")));
  EXPECT_EQ(connection.read_reply().status, 200);
  const http_reply ready = connection.read_reply();
  EXPECT_EQ(ready.status, 200);
  EXPECT_NE(ready.body.find("ready"), std::string::npos);
  EXPECT_EQ(connection.read_reply().status, 404);
  ASSERT_TRUE(connection.send("HEAD /openapi.json HTTP/1.1\r\nHost: t\r\n\r\n"));
  const http_reply head = connection.read_reply(/*head_request=*/true);
  EXPECT_EQ(head.status, 200);
  EXPECT_GT(std::stoul(head.header("content-length")), 100u);
  ASSERT_TRUE(connection.send(get_request("/openapi.json")));
  const http_reply openapi = connection.read_reply();
  EXPECT_EQ(openapi.body.size(), std::stoul(head.header("content-length")));
  EXPECT_FALSE(nlohmann::json::parse(openapi.body, nullptr, false).is_discarded());
}

TEST_F(ServiceTest, ConnectionsOverTheLimitGet503) {
  start([](server_config& c) { c.limits.max_connections = 2; });
  raw_connection first(port_);
  raw_connection second(port_);
  ASSERT_TRUE(first.send(get_request("/healthz")));
  ASSERT_TRUE(second.send(get_request("/healthz")));
  EXPECT_EQ(first.read_reply().status, 200);
  EXPECT_EQ(second.read_reply().status, 200);
  raw_connection third(port_);
  expect_error(third.read_reply(), 503, "unavailable");
  EXPECT_TRUE(third.closed_by_peer(2s));
  ASSERT_TRUE(first.send(get_request("/healthz")));
  EXPECT_EQ(first.read_reply().status, 200);  // existing connections are unaffected
}

TEST_F(ServiceTest, DeleteCancelsARunningJob) {
  start();
  mesher_.set_open(false);
  const http_reply accepted = post("/jobs", gly_);
  ASSERT_EQ(accepted.status, 202);
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (mesher_.runs() == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  const http_reply cancelled = round_trip(port_, "DELETE /jobs/" + id + " HTTP/1.1\r\nHost: t\r\n\r\n");
  EXPECT_EQ(cancelled.status, 200) << cancelled.body;
  const auto final_state = wait_job(id);
  EXPECT_EQ(final_state.at("status"), "cancelled") << final_state;
  EXPECT_EQ(final_state.at("error").at("code"), "cancelled");
  expect_error(get("/jobs/" + id + "/mesh"), 409, "conflict");
}

TEST_F(ServiceTest, JobsOverTheirTimeoutFailAndAreNotCached) {
  start([](server_config& c) { c.limits.job_timeout = 100ms; });
  mesher_.set_open(false);
  const http_reply sync = post("/mesh", gly_);
  expect_error(sync, 503, "timeout");
  const http_reply accepted = post("/jobs", gly_);
  ASSERT_EQ(accepted.status, 202);
  const auto failed = wait_job(nlohmann::json::parse(accepted.body).at("id"));
  EXPECT_EQ(failed.at("status"), "failed");
  EXPECT_EQ(failed.at("error").at("code"), "timeout");
  mesher_.set_open(true);
  const http_reply retried = post("/mesh", gly_);
  EXPECT_EQ(retried.status, 200);
  EXPECT_EQ(retried.header("x-cache"), "miss");
  EXPECT_EQ(mesher_.runs(), 3);
}

TEST_F(ServiceTest, CorsPreflightAndConfiguredOrigins) {
  start([](server_config& c) { c.cors_origins = {"https://lab.example.org"}; });
  const http_reply preflight = round_trip(port_,
                                        "OPTIONS /jobs HTTP/1.1\r\nHost: t\r\nOrigin: https://lab.example.org\r\n"
                                        "Access-Control-Request-Method: POST\r\n\r\n");
  EXPECT_EQ(preflight.status, 204);
  EXPECT_EQ(preflight.header("access-control-allow-origin"), "https://lab.example.org");
  EXPECT_NE(preflight.header("access-control-allow-methods").find("POST"), std::string::npos);
  const http_reply allowed = get("/healthz", "Origin: https://lab.example.org\r\n");
  EXPECT_EQ(allowed.header("access-control-allow-origin"), "https://lab.example.org");
  EXPECT_NE(allowed.header("access-control-expose-headers").find("X-Job-Id"), std::string::npos);
  const http_reply other = get("/healthz", "Origin: https://elsewhere.example\r\n");
  EXPECT_EQ(other.status, 200);
  EXPECT_TRUE(other.header("access-control-allow-origin").empty());
}

TEST_F(ServiceTest, MetricsCountRequestsAndMesherRuns) {
  start();
  ASSERT_EQ(post("/mesh", gly_).status, 200);
  ASSERT_EQ(post("/mesh", gly_).status, 200);
  get("/nowhere");
  const http_reply r = get("/metrics");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.header("content-type").rfind("text/plain; version=0.0.4", 0), 0u);
  EXPECT_NE(r.body.find("tracemesh_http_requests_total{route=\"/mesh\",status=\"200\"} 2\n"), std::string::npos)
      << r.body;
  EXPECT_NE(r.body.find("tracemesh_mesher_runs_total 1\n"), std::string::npos);
  EXPECT_NE(r.body.find("tracemesh_http_requests_total{route=\"(unknown)\",status=\"404\"} 1\n"), std::string::npos);
  EXPECT_NE(r.body.find("tracemesh_cache_responses_total 1\n"), std::string::npos);
}

TEST_F(ServiceTest, ShutdownAnswersWaitingClientsAndStopsAccepting) {
  start([](server_config& c) { c.limits.shutdown_grace = 100ms; });
  mesher_.set_open(false);
  http_reply waiting;
  std::thread client([&] { waiting = post("/mesh", gly_); });
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (mesher_.runs() == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  const auto started = std::chrono::steady_clock::now();
  service_->shutdown();
  EXPECT_LT(std::chrono::steady_clock::now() - started, 3s);
  client.join();
  expect_error(waiting, 503, "shutdown");
  raw_connection after(port_);
  EXPECT_FALSE(after.connected() && after.send(get_request("/healthz")) && after.read_reply().status == 200);
}

TEST_F(ServiceTest, DiskCacheSurvivesARestart) {
  const auto dir = std::filesystem::temp_directory_path() / ("tracemesh-service-test-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  start([&](server_config& c) { c.cache_dir = dir; });
  const http_reply first = post("/mesh", gly_, {{"format", "draco"}});
  ASSERT_EQ(first.status, 200);
  service_->shutdown();
  service_.reset();
  start([&](server_config& c) { c.cache_dir = dir; });
  const http_reply second = post("/mesh", gly_, {{"format", "draco"}});
  EXPECT_EQ(second.status, 200);
  EXPECT_EQ(second.header("x-cache"), "hit");
  EXPECT_EQ(second.body, first.body);
  const auto status_doc = nlohmann::json::parse(get("/jobs/" + first.header("x-job-id")).body);
  EXPECT_EQ(status_doc.at("status"), "done");
  EXPECT_EQ(mesher_.runs(), 1);
  service_->shutdown();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tracemesh::server
