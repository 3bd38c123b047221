// Tests of server/service.hpp and the API it serves (api_handlers.hpp, mesh_job.hpp, job_queue.hpp, cors.hpp through
// a running service): routes, errors, single-flight, back-pressure, cancellation, timeouts, formats, the cache and
// shutdown (service-test-list E, G, J), with a fake mesher behind a gate. The HTTP transport (framing, limits, slow
// and misbehaving clients) is tested in http_server_test.cpp; the real mesher and curl in tests/integration/.
#include "server/service.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/structure/molecule_reader.hpp"
#include "proto/api_types.hpp"
#include "server/jobs/job_id.hpp"
#include "server/storage/content_hash.hpp"
#include "server/service_fixture.hpp"

namespace tracemesh::server::test {
namespace {

class ServiceTest : public service_fixture {};

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
  EXPECT_EQ(doc.at("links").at("mesh"), "/jobs/" + id + "/mesh?format=draco") << "the link names the format";
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

  // Without ?format the job's submitted format is served, and caches must revalidate (the URL is not pinned to
  // one encoding); with ?format the bytes are immutable.
  const http_reply submitted = get("/jobs/" + id + "/mesh");
  ASSERT_EQ(submitted.status, 200);
  EXPECT_EQ(submitted.header("content-type"), "application/vnd.google.draco");
  EXPECT_EQ(submitted.body.substr(0, 5), "DRACO");
  EXPECT_EQ(submitted.header("cache-control"), "no-cache");
  const http_reply off = get("/jobs/" + id + "/mesh?format=off");
  ASSERT_EQ(off.status, 200);
  EXPECT_EQ(off.body.rfind("OFF\n", 0), 0u);
  EXPECT_NE(off.header("cache-control").find("immutable"), std::string::npos);
  EXPECT_NE(off.header("etag"), submitted.header("etag"));

  // A job submitted without a format defaults to OFF.
  const http_reply plain = post("/jobs", gly_, {{"density", "3"}});
  ASSERT_EQ(plain.status, 202) << plain.body;
  const std::string plain_id = nlohmann::json::parse(plain.body).at("id");
  EXPECT_EQ(nlohmann::json::parse(plain.body).at("links").at("mesh"), "/jobs/" + plain_id + "/mesh?format=off");
  EXPECT_EQ(wait_job(plain_id).at("status"), "done");
  EXPECT_EQ(get("/jobs/" + plain_id + "/mesh").header("content-type"), "model/vnd.off");
}

/// The id of the job of `pqr` meshed with the default parameters (server/jobs/job_id.hpp), as the service computes it.
std::string default_job_id(const std::string& pqr) {
  const auto read = read_molecule(pqr, structure_options{}, mesh_limits{}, server_limits{}.max_pqr_bytes);
  EXPECT_TRUE(read.ok());
  return read.ok() ? compute_job_id(read->mol, mesh_params{}) : std::string();
}

TEST_F(ServiceTest, IdenticalConcurrentUploadsRunTheMesherOnce) {
  start([](server_config& c) { c.io_threads = 2; });
  mesher_.set_open(false);
  constexpr int clients = 20;
  std::vector<http_reply> replies(clients);
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) threads.emplace_back([&, i] { replies[i] = post("/mesh", gly_); });
  // Every upload has joined the one held job before it may end (an upload still in flight then would be answered
  // from the cache instead, which this test is not about). EXPECT: the client threads must be joined either way.
  const std::string id = default_job_id(gly_);
  EXPECT_TRUE(eventually([&] { return service_->jobs().listeners(id) == clients; }));
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
  start([](server_config& c) {
    c.limits.max_queue = 1;
    c.small_job_workers = 0;  // one-atom jobs would otherwise run on the small-job lane instead of waiting
  });
  mesher_.set_open(false);
  ASSERT_EQ(post("/jobs", atom_line(1, 0.0)).status, 202);  // runs
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 1; }));
  ASSERT_EQ(post("/jobs", atom_line(1, 1.0)).status, 202);  // waits
  const http_reply refused = post("/jobs", atom_line(1, 2.0));
  expect_error(refused, 429, "queue_full");
  EXPECT_EQ(refused.header("retry-after"), "5");
  expect_error(get("/readyz"), 503, "unavailable");
  EXPECT_EQ(get("/healthz").status, 200);
  mesher_.set_open(true);
  EXPECT_TRUE(eventually([&] { return get("/readyz").status == 200; }));
  EXPECT_EQ(post("/jobs", atom_line(1, 2.0)).status, 202);
}

TEST_F(ServiceTest, ConcurrentUploadsBeyondTheLimitGet429) {
  start([](server_config& c) { c.limits.max_concurrent_uploads = 1; });
  const std::string full = upload_request("/mesh", gly_);
  raw_connection holding(port_);
  ASSERT_TRUE(holding.send(full.substr(0, full.size() - 10)));  // an upload still being received
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 1; }));
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
  // The absolute form is a request target a server must accept (RFC 9112 §3.2.2); the others are refused
  // (http_server_test: MethodsTargetsAndHeadRequests).
  EXPECT_EQ(round_trip(port_, "GET http://test/healthz HTTP/1.1\r\nHost: test\r\n\r\n").status, 200);
  EXPECT_EQ(round_trip(port_, "GET HTTP://test:80/healthz?x=1 HTTP/1.1\r\nHost: test\r\n\r\n").status, 200);
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
  // Client bytes quoted in a message may be invalid UTF-8: replaced in the JSON, never a crash (a fuzz find).
  const http_reply invalid_utf8 = post("/mesh?form\xff" "at=draco", gly_);
  expect_error(invalid_utf8, 400, "invalid_argument");
  EXPECT_NE(invalid_utf8.body.find("form\xEF\xBF\xBD" "at"), std::string::npos) << invalid_utf8.body;
  expect_error(post("/mesh", gly_, {{"\xc3\x28", "1"}}), 400, "invalid_argument");
  expect_error(post("/mesh", gly_, {{"density", "1\xff"}}), 400, "invalid_argument");
  expect_error(post("/mesh", "ATOM 1 N GLY 1 \xfe\xff 0 0 0 1.5\n"), 400, "invalid_input");
  expect_error(post("/mesh", gly_, {{"pqr", "twice"}}), 400, "invalid_input");
  // A repeated parameter is named (a sweep found "a form field is given twice" without the field).
  const http_reply twice_in_form = post("/mesh", gly_, {{"density", "2"}, {"density", "0.5"}});
  expect_error(twice_in_form, 400, "invalid_argument");
  EXPECT_NE(twice_in_form.body.find("form field 'density' given twice"), std::string::npos) << twice_in_form.body;
  const http_reply twice_in_query = post("/mesh?density=2&density=0.5", gly_);
  expect_error(twice_in_query, 400, "invalid_argument");
  EXPECT_NE(twice_in_query.body.find("query parameter 'density' given twice"), std::string::npos)
      << twice_in_query.body;
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

TEST_F(ServiceTest, DeleteCancelsARunningJob) {
  start();
  mesher_.set_open(false);
  const http_reply accepted = post("/jobs", gly_);
  ASSERT_EQ(accepted.status, 202);
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 1; }));
  const http_reply cancelled = withdraw(accepted);
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
  expect_error(sync, 504, "timeout");
  EXPECT_TRUE(sync.header("retry-after").empty()) << "the same input would time out again";
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
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 1; }));
  // The gate stays closed: shutdown() returns only because it stops the held job after its grace (a shutdown that
  // waited for the job would hang here, until ctest's timeout).
  service_->shutdown();
  client.join();
  expect_error(waiting, 503, "shutdown");
  EXPECT_EQ(waiting.header("retry-after"), "5");
  EXPECT_EQ(waiting.header("connection"), "close");
  raw_connection after(port_);
  EXPECT_FALSE(after.connected() && after.send(get_request("/healthz")) && after.read_reply().status == 200);
}

TEST_F(ServiceTest, DiskCacheSurvivesARestart) {
  const auto dir = std::filesystem::temp_directory_path() / ("tracemesh-service-test-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const auto on_disk = [&](server_config& c) {
    c.cache_dir = dir;
    c.job_dir = dir / "jobs";
  };
  start(on_disk);
  const http_reply first = post("/mesh", gly_, {{"format", "draco"}});
  ASSERT_EQ(first.status, 200);
  service_->shutdown();
  service_.reset();
  start(on_disk);
  const http_reply second = post("/mesh", gly_, {{"format", "draco"}});
  EXPECT_EQ(second.status, 200);
  EXPECT_EQ(second.header("x-cache"), "hit");
  EXPECT_EQ(second.body, first.body);
  const auto status_doc = nlohmann::json::parse(get("/jobs/" + first.header("x-job-id")).body);
  EXPECT_EQ(status_doc.at("status"), "done");
  EXPECT_EQ(status_doc.at("links").at("mesh"), "/jobs/" + first.header("x-job-id") + "/mesh?format=draco")
      << "the job store remembers the submitted format across the restart";
  expect_error(request("DELETE", "/jobs/" + first.header("x-job-id"), "X-Job-Token: x\r\n"), 409, "conflict");
  EXPECT_EQ(mesher_.runs(), 1);
  service_->shutdown();
  std::filesystem::remove_all(dir);
}

TEST_F(ServiceTest, DeletingAFinishedJobIsAConflictAndCancellingTwiceIsHarmless) {
  start();
  const http_reply accepted = post("/jobs", gly_);
  ASSERT_EQ(accepted.status, 202);
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  ASSERT_EQ(wait_job(id).at("status"), "done");
  const http_reply finished = withdraw(accepted);
  expect_error(finished, 409, "conflict");
  EXPECT_NE(finished.body.find("done"), std::string::npos) << finished.body;
  EXPECT_EQ(wait_job(id).at("status"), "done") << "left as it was";

  mesher_.set_open(false);
  const http_reply other = post("/jobs", atom_line(1, 0.0));
  ASSERT_EQ(other.status, 202);
  const std::string other_id = nlohmann::json::parse(other.body).at("id");
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 2; }));
  EXPECT_EQ(withdraw(other).status, 200);
  EXPECT_EQ(wait_job(other_id).at("status"), "cancelled");
  const http_reply again = withdraw(other);
  EXPECT_EQ(again.status, 200) << again.body;
  EXPECT_EQ(nlohmann::json::parse(again.body).at("status"), "cancelled");
  expect_error(request("DELETE", "/jobs/" + std::string(64, 'e'), "X-Job-Token: abc\r\n"), 404, "not_found");
}

TEST_F(ServiceTest, JobIdsThatAreNotSha256HexNeverReachTheCache) {
  const auto dir = std::filesystem::temp_directory_path() / ("tracemesh-ids-test-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  start([&](server_config& c) { c.cache_dir = dir; });
  const std::string hex64(64, 'a');
  const std::vector<std::string> ids = {
      "..%2f..%2fetc%2fpasswd", "..%5c..%5cwindows%5cwin.ini", "%2e%2e%2f", "%2e%2e", "..", "%2fetc%2fpasswd",
      "ABCDEF", "0123", "%00", hex64 + "%00", hex64.substr(1), hex64 + "a", std::string(64, 'A'),
      hex64.substr(3) + "%EF%BC%90",  // a fullwidth digit zero: a look-alike of '0'
      hex64.substr(1) + "%D0%B0",     // a Cyrillic 'а'
      hex64 + "%20", "%20" + hex64, "0x" + hex64.substr(2), std::string(5000, 'a')};
  for (const std::string& id : ids) {
    expect_error(get("/jobs/" + id), 400, "invalid_argument");
    expect_error(get("/jobs/" + id + "/mesh"), 400, "invalid_argument");
    expect_error(request("DELETE", "/jobs/" + id), 400, "invalid_argument");
  }
  for (const char* target : {"/jobs/../../etc/passwd", "/jobs//etc/passwd", "/jobs/a/b/mesh", "/jobs/"}) {
    expect_error(get(target), 404, "not_found");
  }
  expect_error(get("/jobs/" + hex64), 404, "not_found");
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) files += entry.is_regular_file();
  EXPECT_EQ(files, 0u) << "no request above may create anything in the cache";
  EXPECT_EQ(service_->cache().stats().misses, 0u) << "a job's status comes from the queue or the job store";
  service_->shutdown();
  std::filesystem::remove_all(dir);
}

TEST_F(ServiceTest, AClientLeavingASynchronousRequestDoesNotCancelItsJob) {
  start();
  mesher_.set_open(false);
  {
    raw_connection leaving(port_);
    ASSERT_TRUE(leaving.send(upload_request("/mesh", gly_)));
    ASSERT_TRUE(eventually([&] { return mesher_.runs() == 1; }));
    leaving.close(/*reset=*/true);
  }
  // Time for the server to see the reset before the job ends; what follows holds whether it saw it or not.
  std::this_thread::sleep_for(20ms);
  mesher_.set_open(true);
  ASSERT_TRUE(jobs_settled());
  const http_reply later = post("/mesh", gly_);
  ASSERT_EQ(later.status, 200);
  EXPECT_EQ(later.header("x-cache"), "hit") << "the abandoned job finished and was cached";
  EXPECT_EQ(mesher_.runs(), 1);
  EXPECT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 0; }));
}

TEST_F(ServiceTest, UploadBytesInFlightAreBoundedTogether) {
  const std::string full = upload_request("/mesh", gly_);
  const std::size_t header_end = full.find("\r\n\r\n") + 4;
  const std::size_t body_bytes = full.size() - header_end;
  start([&](server_config& c) { c.limits.max_upload_bytes_in_flight = body_bytes + body_bytes / 2; });

  // One upload holds the bytes it has received while the rest of its body is still arriving.
  raw_connection holding(port_);
  ASSERT_TRUE(holding.send(full.substr(0, full.size() - 10)));
  ASSERT_TRUE(eventually([&] { return service_->uploads().bytes_in_flight() == body_bytes - 10; }));

  // A second upload of the same size is admitted (it has sent nothing yet), and refused with 429 once its bytes
  // no longer fit next to the first one's; the connection is closed (the rest of its body is not read).
  raw_connection second(port_);
  ASSERT_TRUE(second.send(full));
  const http_reply refused = second.read_reply();
  expect_error(refused, 429, "queue_full");
  EXPECT_EQ(refused.header("retry-after"), "5");
  EXPECT_EQ(refused.header("connection"), "close");

  // A chunked upload is admitted (its size is unknown), then refused once what it sent no longer fits.
  raw_connection chunked(port_);
  const std::string boundary = "----tracemesh-test-boundary";
  ASSERT_TRUE(chunked.send("POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; boundary=" +
                           boundary + "\r\nTransfer-Encoding: chunked\r\n\r\n"));
  const std::string body = testing::multipart_body(boundary, gly_);
  std::ostringstream chunk;
  chunk << std::hex << body.size() << "\r\n" << body << "\r\n";
  chunked.send(chunk.str());
  const http_reply cut = chunked.read_reply();
  expect_error(cut, 429, "queue_full");
  EXPECT_EQ(cut.header("connection"), "close");
  EXPECT_TRUE(chunked.closed_by_peer());

  ASSERT_TRUE(holding.send(full.substr(full.size() - 10)));
  EXPECT_EQ(holding.read_reply().status, 200);
  EXPECT_TRUE(eventually([&] { return service_->uploads().bytes_in_flight() == 0; }));
  EXPECT_EQ(service_->uploads().uploads_in_flight(), 0u);
  EXPECT_EQ(post("/mesh", gly_).status, 200) << "the bytes were released";
}

TEST_F(ServiceTest, DeclaredButUnsentUploadBytesHoldNoBudget) {
  // Finding 4: five uploads declaring 255 MB and sending nothing exhausted the 1 GiB budget. Here: five uploads
  // declaring the largest accepted body each, against a budget of less than two of them.
  const std::uint64_t max_upload = 256 * 1024;
  start([&](server_config& c) { c.limits.max_upload_bytes_in_flight = max_upload + max_upload / 2; });
  const std::string declared_header = "POST /mesh HTTP/1.1\r\nHost: t\r\nContent-Type: multipart/form-data; "
                                      "boundary=b\r\nContent-Length: " + std::to_string(max_upload) + "\r\n\r\n";
  std::vector<std::unique_ptr<raw_connection>> silent;
  for (int i = 0; i < 5; ++i) {
    silent.push_back(std::make_unique<raw_connection>(port_));
    ASSERT_TRUE(silent.back()->send(declared_header));
  }
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 5; }));
  EXPECT_EQ(service_->uploads().bytes_in_flight(), 0u) << "nothing was received, nothing is held";
  EXPECT_EQ(post("/mesh", gly_).status, 200) << "a real upload still fits in the budget";
}

TEST_F(ServiceTest, MetricsParseAsPrometheusTextAfterRealTraffic) {
  start();
  ASSERT_EQ(post("/mesh", gly_).status, 200);
  ASSERT_EQ(post("/mesh", gly_).status, 200);
  mesher_.set_open(false);
  const http_reply accepted = post("/jobs", atom_line(1, 0.0));
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 2; }));
  withdraw(accepted);
  ASSERT_EQ(wait_job(id).at("status"), "cancelled");
  get("/nowhere");
  const http_reply r = get("/metrics");
  ASSERT_EQ(r.status, 200);

  // The exposition format: # HELP/# TYPE before a family's samples, counters named *_total, histogram buckets
  // cumulative and ending with le="+Inf" equal to _count, every value a number.
  std::map<std::string, std::string> type_of;
  std::map<std::string, std::vector<std::pair<std::string, double>>> buckets;
  std::map<std::string, double> counts;
  std::istringstream lines(r.body);
  std::string line;
  while (std::getline(lines, line)) {
    ASSERT_FALSE(line.empty());
    if (line.rfind("# HELP ", 0) == 0) continue;
    if (line.rfind("# TYPE ", 0) == 0) {
      std::istringstream words(line.substr(7));
      std::string name, type;
      words >> name >> type;
      EXPECT_TRUE(type == "counter" || type == "gauge" || type == "histogram") << line;
      EXPECT_TRUE(type_of.emplace(name, type).second) << "family typed twice: " << line;
      if (type == "counter") {
        EXPECT_EQ(name.substr(name.size() - 6), "_total") << line;
      }
      continue;
    }
    const std::size_t space = line.rfind(' ');
    const std::string series = line.substr(0, space);
    std::size_t parsed = 0;
    const double value = std::stod(line.substr(space + 1), &parsed);
    EXPECT_EQ(parsed, line.size() - space - 1) << line;
    const std::string name = series.substr(0, series.find('{'));
    std::string family = name;
    for (const std::string suffix : {"_bucket", "_sum", "_count"}) {
      const std::string base = name.size() > suffix.size() ? name.substr(0, name.size() - suffix.size()) : "";
      if (name.size() > suffix.size() && name.compare(base.size(), suffix.size(), suffix) == 0 &&
          type_of.count(base) && type_of[base] == "histogram") {
        family = base;
      }
    }
    ASSERT_TRUE(type_of.count(family)) << "sample before its # TYPE: " << line;
    if (name == family + "_bucket") {
      const std::size_t le = series.find("le=\"") + 4;
      buckets[family].emplace_back(series.substr(le, series.find('"', le) - le), value);
    }
    if (name == family + "_count") counts[family] = value;
  }
  ASSERT_TRUE(buckets.count("tracemesh_job_seconds"));
  for (const auto& [family, series] : buckets) {
    for (std::size_t i = 1; i < series.size(); ++i) EXPECT_GE(series[i].second, series[i - 1].second) << family;
    EXPECT_EQ(series.back().first, "+Inf") << family;
    EXPECT_EQ(series.back().second, counts.at(family)) << family;
  }
  EXPECT_EQ(counts.at("tracemesh_job_seconds"), 2) << "one done, one cancelled";
}

// ---- method, refine and the trace parameters ----------------------------------------------------------------

/// The id a POST /jobs answers with (202 or 200), or "" on any other status.
std::string job_id_of(const http_reply& r) {
  if (r.status != 202 && r.status != 200) return {};
  return nlohmann::json::parse(r.body).at("id");
}

/// A query string from fields: "?a=1&b=2".
std::string query_of(const std::vector<std::pair<std::string, std::string>>& fields) {
  std::string query;
  for (const auto& [name, value] : fields) query += (query.empty() ? "?" : "&") + name + "=" + value;
  return query;
}

const std::vector<std::pair<std::string, std::string>> trace_fields = {
    {"method", "trace"},     {"refine", "none"},           {"trace_degree", "12"},
    {"trace_step", "0.25"},  {"trace_cos_bound", "0.95"},  {"trace_extreme_tolerance", "0.01"}};

void expect_trace_fields(const mesh_params& params) {
  EXPECT_EQ(params.method, mesh_method::trace);
  EXPECT_EQ(params.refine, refine_mode::none);
  EXPECT_EQ(params.trace.legendre_degree, 12);
  EXPECT_EQ(params.trace.step_fraction, 0.25);
  EXPECT_EQ(params.trace.cos_bound, 0.95);
  EXPECT_EQ(params.trace.extreme_tolerance, 0.01);
}

TEST_F(ServiceTest, MethodRefineAndTraceParametersAreReadFromFormFieldsAndQueryParameters) {
  start();
  // Form fields, synchronous route.
  const http_reply form = post("/mesh", gly_, trace_fields);
  ASSERT_EQ(form.status, 200) << form.body;
  expect_trace_fields(mesher_.last_params());
  // The same parameters as query parameters (other spellings of the same numbers) are the same job.
  const http_reply query = post("/mesh?method=trace&refine=none&trace_degree=12.0&trace_step=2.5e-1"
                                "&trace_cos_bound=0.950&trace_extreme_tolerance=1e-2",
                                gly_);
  ASSERT_EQ(query.status, 200) << query.body;
  EXPECT_EQ(query.header("x-job-id"), form.header("x-job-id"));
  EXPECT_EQ(query.header("x-cache"), "hit");
  EXPECT_EQ(mesher_.runs(), 1);

  // Asynchronous route, query parameters, one parameter at a time.
  for (const auto& [name, value] : trace_fields) {
    std::vector<std::pair<std::string, std::string>> fields = {{name, value}};
    if (name != "method") fields.emplace_back("method", "trace");
    const http_reply accepted = post("/jobs" + query_of(fields), gly_);
    ASSERT_TRUE(accepted.status == 202 || accepted.status == 200) << name << ": " << accepted.body;
    ASSERT_EQ(wait_job(job_id_of(accepted)).at("status"), "done") << name;
  }
  // Asynchronous route, form fields: the job ran with them.
  const http_reply jobs_form = post("/jobs", atom_line(1, 0.0), trace_fields);
  ASSERT_EQ(jobs_form.status, 202) << jobs_form.body;
  ASSERT_EQ(wait_job(job_id_of(jobs_form)).at("status"), "done");
  expect_trace_fields(mesher_.last_params());
  const http_reply jobs_query = post("/jobs" + query_of(trace_fields), atom_line(1, 0.0));
  EXPECT_EQ(job_id_of(jobs_query), job_id_of(jobs_form)) << "form fields and query parameters are the same job";

  // A parameter in both the query and the form: the same value is one parameter, different values are refused.
  const http_reply agreeing = post("/jobs?method=lattice&refine=none", atom_line(1, 5.0), {{"method", "lattice"}});
  ASSERT_EQ(agreeing.status, 202) << agreeing.body;
  ASSERT_EQ(wait_job(job_id_of(agreeing)).at("status"), "done");
  EXPECT_EQ(mesher_.last_params().method, mesh_method::lattice);
  EXPECT_EQ(mesher_.last_params().refine, refine_mode::none);
  expect_error(post("/jobs?method=trace&refine=none", atom_line(1, 5.0), {{"method", "lattice"}}), 400,
               "invalid_argument");
}

TEST_F(ServiceTest, BadMethodRefineAndTraceParametersAre400NamingTheParameter) {
  start();
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"method", "Trace"},  {"method", ""},   {"method", "marching"},     {"refine", "partial"},
      {"refine", "FULL"},   {"refine", "1"},  {"trace_degree", "2.5"},    {"trace_degree", "1"},
      {"trace_degree", "31"}, {"trace_degree", "1e300"}, {"trace_degree", "ten"}, {"trace_step", "0"},
      {"trace_step", "2.5"},  {"trace_step", "nan"}, {"trace_cos_bound", "1"}, {"trace_cos_bound", "0.4"},
      {"trace_cos_bound", "-0.9"}, {"trace_extreme_tolerance", "0"}, {"trace_extreme_tolerance", "0.3"},
      {"trace_extreme_tolerance", "1e-2x"}};
  for (const auto& [name, value] : bad) {
    for (const std::string route : {"/mesh", "/jobs"}) {
      // The trace fields are validated whatever the method: a request wrong for one method is wrong for both.
      const http_reply as_form = post(route, gly_, {{name, value}});
      expect_error(as_form, 400, "invalid_argument");
      const std::string form_message = nlohmann::json::parse(as_form.body)["error"]["message"];
      EXPECT_EQ(form_message.rfind(name, 0), 0u) << name << "=" << value << ": " << form_message;
      const http_reply as_query = post(route + "?" + name + "=" + value, gly_);
      expect_error(as_query, 400, "invalid_argument");
      const std::string query_message = nlohmann::json::parse(as_query.body)["error"]["message"];
      EXPECT_EQ(query_message.rfind(name, 0), 0u) << name << "=" << value << ": " << query_message;
    }
  }
  expect_error(post("/mesh?trace-degree=12", gly_), 400, "invalid_argument");  // the CLI's spelling is not a field
  expect_error(post("/mesh", gly_, {{"trace_degree", "12"}, {"trace_degree", "13"}}), 400, "invalid_argument");
  EXPECT_EQ(mesher_.runs(), 0);
}

TEST_F(ServiceTest, JobIdsDifferByMethodAndRefineAndDefaultsSpelledOutAreTheSameJob) {
  // Eight different jobs are posted one after the other: with the fixture's queue of 4 and one worker, a worker
  // slowed by a loaded machine let the queue fill and a post get 429 (seen once under ctest -j 2). The queue limit
  // is not what this test is about.
  start([](server_config& config) { config.limits.max_queue = 64; });
  const mesh_params defaults;
  const auto id_for = [&](const std::vector<std::pair<std::string, std::string>>& fields) {
    const std::string id = job_id_of(post("/jobs", gly_, fields));
    EXPECT_TRUE(is_valid_job_id(id)) << id;
    return id;
  };
  const std::string implicit = id_for({});
  EXPECT_EQ(id_for({{"method", method_name(defaults.method)}}), implicit);
  EXPECT_EQ(id_for({{"refine", refine_name(defaults.refine)}}), implicit);
  EXPECT_EQ(id_for({{"method", method_name(defaults.method)},
                    {"refine", refine_name(defaults.refine)},
                    {"density", "1.0"},
                    {"d", "-1"},
                    {"t0", "1"},
                    {"trace_degree", std::to_string(defaults.trace.legendre_degree)},
                    {"trace_step", proto::canonical_number(defaults.trace.step_fraction)},
                    {"trace_cos_bound", proto::canonical_number(defaults.trace.cos_bound)},
                    {"trace_extreme_tolerance", proto::canonical_number(defaults.trace.extreme_tolerance)}}),
            implicit)
      << "every default spelled out is the job with nothing given";

  const std::string lattice_full = id_for({{"method", "lattice"}, {"refine", "full"}});
  const std::string lattice_none = id_for({{"method", "lattice"}, {"refine", "none"}});
  const std::string trace_full = id_for({{"method", "trace"}, {"refine", "full"}});
  const std::string trace_none = id_for({{"method", "trace"}, {"refine", "none"}});
  EXPECT_EQ(std::set<std::string>({lattice_full, lattice_none, trace_full, trace_none}).size(), 4u)
      << "method and refine each make a different job";
  EXPECT_EQ(id_for({{"method", "trace"}}), defaults.refine == refine_mode::full ? trace_full : trace_none);

  // For the trace method every trace parameter is part of the job; spelled-out defaults are not.
  EXPECT_NE(id_for({{"method", "trace"}, {"trace_degree", "12"}}), trace_full);
  EXPECT_NE(id_for({{"method", "trace"}, {"trace_step", "0.25"}}), trace_full);
  EXPECT_NE(id_for({{"method", "trace"}, {"trace_cos_bound", "0.95"}}), trace_full);
  EXPECT_NE(id_for({{"method", "trace"}, {"trace_extreme_tolerance", "0.01"}}), trace_full);
  EXPECT_EQ(id_for({{"method", "trace"}, {"refine", "full"}, {"trace_degree", "10.0"}}), trace_full);
  // For the lattice method they change nothing, so they do not make another job.
  EXPECT_EQ(id_for({{"method", "lattice"}, {"trace_degree", "12"}, {"trace_step", "0.25"}}), lattice_full);
  EXPECT_TRUE(jobs_settled());
}

TEST_F(ServiceTest, ReportsEchoMethodRefineAndTheTraceSection) {
  start();
  const http_reply trace = post("/jobs", gly_, {{"method", "trace"}, {"refine", "none"}, {"trace_step", "0.25"},
                                                 {"density", "4"}});
  const auto trace_done = wait_job(job_id_of(trace));
  ASSERT_EQ(trace_done.at("status"), "done") << trace_done;
  const nlohmann::json& report = trace_done.at("report");
  EXPECT_EQ(report.at("method"), "trace");
  EXPECT_EQ(report.at("refine"), "none");
  const nlohmann::json& section = report.at("trace");
  ASSERT_TRUE(section.is_object()) << report;
  const mesh_params defaults;
  EXPECT_EQ(section.at("parameters"),
            (nlohmann::json{{"legendre_degree", defaults.trace.legendre_degree},
                            {"step_fraction", 0.25},
                            {"step", 0.125},
                            {"line_spacing", 0.5},
                            {"cos_bound", defaults.trace.cos_bound},
                            {"extreme_tolerance", defaults.trace.extreme_tolerance}}));
  EXPECT_EQ(section.at("lines"), 11);
  EXPECT_EQ(section.at("polygons"), 4);
  EXPECT_EQ(section.at("fallback_loops"), 0);
  EXPECT_EQ(section.at("field_evaluations_per_vertex"), 10.0);

  const http_reply lattice = post("/jobs", gly_, {{"method", "lattice"}, {"refine", "none"}});
  const auto lattice_done = wait_job(job_id_of(lattice));
  ASSERT_EQ(lattice_done.at("status"), "done") << lattice_done;
  EXPECT_EQ(lattice_done.at("report").at("method"), "lattice");
  EXPECT_EQ(lattice_done.at("report").at("refine"), "none");
  EXPECT_TRUE(lattice_done.at("report").at("trace").is_null());
}

TEST_F(ServiceTest, ATraceJobReportsTheTracingStageAndItsProgress) {
  start([](server_config& c) { c.workers = 2; });
  mesher_.set_open(false);
  const std::string trace = job_id_of(post("/jobs", gly_, {{"method", "trace"}}));
  const std::string lattice = job_id_of(post("/jobs", gly_, {{"method", "lattice"}}));
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 2; }));
  nlohmann::json trace_doc, lattice_doc;
  ASSERT_TRUE(eventually([&] {
    trace_doc = nlohmann::json::parse(get("/jobs/" + trace).body);
    lattice_doc = nlohmann::json::parse(get("/jobs/" + lattice).body);
    return trace_doc.at("stage") == "tracing" && lattice_doc.at("stage") == "sampling";
  })) << trace_doc << lattice_doc;
  EXPECT_EQ(trace_doc.at("status"), "running");
  EXPECT_GT(trace_doc.at("progress").get<double>(), lattice_doc.at("progress").get<double>())
      << "tracing comes after sampling";
  EXPECT_LT(trace_doc.at("progress").get<double>(), 1.0);
  mesher_.set_open(true);
  EXPECT_EQ(wait_job(trace).at("progress"), 1.0);
  EXPECT_EQ(wait_job(lattice).at("progress"), 1.0);
}

TEST_F(ServiceTest, EveryCoreErrorCodeIsDocumented) {
  const std::set<std::string> documented = documented_error_codes();
  for (const errc code : {errc::invalid_input, errc::nothing_to_mesh, errc::invalid_argument, errc::limit_exceeded,
                          errc::cancelled, errc::io_error, errc::internal_error}) {
    EXPECT_EQ(documented.count(errc_name(code)), 1u) << errc_name(code);
  }
  for (const char* code : {job_error::cancelled, job_error::timeout, job_error::shutdown}) {
    EXPECT_EQ(documented.count(code), 1u) << code;
  }
}

}  // namespace
}  // namespace tracemesh::server::test
