// Issue 12, "one client cannot hurt another", through a running service on a loopback port with real sockets:
// slow upload bodies are cut with 408 (finding 4), per-client limits on connections, uploads and jobs (by IP, or
// by bearer token), and the small-job lane (finding 10).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test {
namespace {

class ClientIsolationTest : public service_fixture {
 protected:
  /// The request line and header of `request` (a complete request as upload_request() builds it).
  static std::string header_of(const std::string& request) { return request.substr(0, body_start(request)); }
  static std::size_t body_start(const std::string& request) { return request.find("\r\n\r\n") + 4; }
  /// A molecule of `atoms` atoms in a row, 2 Å apart.
  static std::string row_of_atoms(int atoms) {
    std::string pqr;
    for (int i = 0; i < atoms; ++i) pqr += atom_line(i + 1, 2.0 * i);
    return pqr;
  }
  /// The message of an error reply.
  static std::string message_of(const http_reply& r) {
    const auto doc = nlohmann::json::parse(r.body, nullptr, false);
    return doc.is_discarded() ? std::string() : doc["error"].value("message", "");
  }
};

TEST_F(ClientIsolationTest, ASlowUploadBodyIsAnswered408AndItsSlotFreed) {
  start([](server_config& c) {
    c.limits.request_timeout = 30s;  // the whole-request deadline is not what cuts it
    c.limits.min_upload_bytes_per_second = 1000;
    c.limits.upload_rate_grace = 200ms;
  });
  const std::string full = upload_request("/mesh", gly_);
  raw_connection slow(port_);
  std::size_t sent = body_start(full) + 5;
  ASSERT_TRUE(slow.send(full.substr(0, sent)));
  // A real slow client: one byte every 100 ms (10 B/s), until the server answers (its last byte is never sent:
  // only the rate limit can end this upload).
  while (sent + 1 < full.size() && !slow.closed_by_peer(100ms)) {
    if (!slow.send(full.substr(sent++, 1))) break;
  }
  const http_reply cut = slow.read_reply();
  expect_error(cut, 408, "request_timeout");
  EXPECT_EQ(cut.header("connection"), "close");
  EXPECT_LT(sent, full.size()) << "cut before its body was complete";
  EXPECT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 0; })) << "its slot was freed";
  EXPECT_EQ(post("/mesh", gly_).status, 200);
}

TEST_F(ClientIsolationTest, SixtyFourSlowClientsDoNotLockOthersOutOfUploads) {
  start([](server_config& c) {
    c.limits.request_timeout = 60s;
    c.limits.max_concurrent_uploads = 64;
    c.limits.max_uploads_per_client = 1000;      // 64 clients share the loopback address here
    c.limits.max_connections_per_client = 1000;
    c.limits.min_upload_bytes_per_second = 1000;
    c.limits.upload_rate_grace = 1s;
  });
  const std::string full = upload_request("/mesh", gly_);
  std::vector<std::unique_ptr<raw_connection>> slow;
  for (int i = 0; i < 64; ++i) {
    slow.push_back(std::make_unique<raw_connection>(port_, 5s));
    ASSERT_TRUE(slow.back()->send(full.substr(0, body_start(full) + 10)));
  }
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 64; }));
  expect_error(post("/mesh", gly_), 429, "queue_full");  // they hold every upload slot...

  // ...until they fall behind the minimum rate: each is answered 408 and its slot freed.
  ASSERT_EQ(slow.front()->read_reply().status, 408);
  for (std::size_t i = 1; i < slow.size(); ++i) EXPECT_EQ(slow[i]->read_reply().status, 408) << i;
  EXPECT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 0; }));
  EXPECT_EQ(post("/mesh", gly_).status, 200);
}

TEST_F(ClientIsolationTest, AClientOverItsConnectionLimitGets429ButHealthAnswers) {
  start([](server_config& c) { c.limits.max_connections_per_client = 2; });
  raw_connection first(port_);
  raw_connection second(port_);
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 2; }));

  raw_connection third(port_);
  ASSERT_TRUE(third.send(tracemesh::testing::get_request("/jobs/" + std::string(64, '0'))));
  const http_reply refused = third.read_reply();
  expect_error(refused, 429, "client_limit");
  EXPECT_EQ(refused.header("retry-after"), "5");
  EXPECT_NE(message_of(refused).find("max_connections_per_client"), std::string::npos) << refused.body;
  EXPECT_TRUE(third.closed_by_peer());

  raw_connection health(port_);
  ASSERT_TRUE(health.send(tracemesh::testing::get_request("/healthz")));
  EXPECT_EQ(health.read_reply().status, 200) << "/healthz always answers";
  raw_connection ready(port_);
  ASSERT_TRUE(ready.send(tracemesh::testing::get_request("/readyz")));
  EXPECT_EQ(ready.read_reply().status, 200) << "/readyz always answers";

  first.close();
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 1; }));
  EXPECT_EQ(get("/jobs/" + std::string(64, '0')).status, 404) << "a freed connection slot serves again";
}

TEST_F(ClientIsolationTest, OneClientsSurplusConnectionsGiveWayToAnotherClient) {
  start([](server_config& c) {
    c.limits.max_connections = 4;
    c.limits.max_connections_per_client = 2;
  });
  // Client A (127.0.0.1): two busy connections (a request header arriving), then two over its limit, idle.
  raw_connection busy_1(port_);
  raw_connection busy_2(port_);
  ASSERT_TRUE(busy_1.send("GET /healthz HTTP/1.1\r\n"));
  ASSERT_TRUE(busy_2.send("GET /healthz HTTP/1.1\r\n"));
  raw_connection surplus_1(port_);
  raw_connection surplus_2(port_);
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 4; }));

  // Client B (127.0.0.2) over the server's limit: one of A's surplus connections is closed for it.
  raw_connection other(port_, 20s, 0, 0x7f000002);
  ASSERT_TRUE(other.connected());
  ASSERT_TRUE(other.send(tracemesh::testing::get_request("/jobs/" + std::string(64, '0'))));
  EXPECT_EQ(other.read_reply().status, 404) << "served, not 503";
  EXPECT_TRUE(eventually([&] { return surplus_1.closed_by_peer(1ms) || surplus_2.closed_by_peer(1ms); }));
}

TEST_F(ClientIsolationTest, UploadsAreLimitedPerBearerTokenNotAcrossClients) {
  const std::filesystem::path tokens =
      std::filesystem::temp_directory_path() / ("tracemesh-tokens-" + std::to_string(::getpid()));
  std::ofstream(tokens) << "alice-token-0123456789\nbob-token-0123456789\n";
  start([&](server_config& c) {
    c.auth_token_file = tokens;
    c.limits.max_uploads_per_client = 2;
  });
  std::filesystem::remove(tokens);
  const std::string alice = "Authorization: Bearer alice-token-0123456789\r\n";
  const std::string bob = "Authorization: Bearer bob-token-0123456789\r\n";
  const std::string alice_upload = upload_request("/mesh", gly_, {}, alice);

  raw_connection held_1(port_);
  raw_connection held_2(port_);
  ASSERT_TRUE(held_1.send(header_of(alice_upload)));
  ASSERT_TRUE(held_2.send(header_of(alice_upload)));
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 2; }));

  const http_reply refused = round_trip(port_, alice_upload);
  expect_error(refused, 429, "client_limit");
  EXPECT_EQ(refused.header("retry-after"), "5");
  EXPECT_NE(message_of(refused).find("max_uploads_per_client"), std::string::npos) << refused.body;
  EXPECT_EQ(round_trip(port_, upload_request("/mesh", gly_, {}, bob)).status, 200) << "another client uploads";

  ASSERT_TRUE(held_1.send(alice_upload.substr(body_start(alice_upload))));
  EXPECT_EQ(held_1.read_reply().status, 200);
  EXPECT_EQ(round_trip(port_, alice_upload).status, 200) << "a finished upload frees the client's slot";
}

TEST_F(ClientIsolationTest, JobsQueuedOrRunningAreLimitedPerClient) {
  start([](server_config& c) { c.limits.max_jobs_per_client = 1; });
  mesher_.set_open(false);
  const http_reply accepted = post("/jobs", atom_line(1, 0.0));
  ASSERT_EQ(accepted.status, 202);
  const http_reply refused = post("/jobs", atom_line(1, 5.0));
  expect_error(refused, 429, "client_limit");
  EXPECT_EQ(refused.header("retry-after"), "5");
  EXPECT_NE(message_of(refused).find("max_jobs_per_client"), std::string::npos) << refused.body;

  mesher_.set_open(true);
  EXPECT_EQ(wait_job(nlohmann::json::parse(accepted.body).at("id").get<std::string>()).value("status", ""), "done");
  EXPECT_TRUE(eventually([&] { return post("/jobs", atom_line(1, 5.0)).status == 202; }))
      << "a finished job frees the client's slot";
}

TEST_F(ClientIsolationTest, ASmallJobCompletesWhileABigOneRunsOnTheOnlyWorker) {
  start([](server_config& c) {
    c.workers = 1;
    c.small_job_workers = 1;
    c.limits.small_job_max_atoms = 10;
  });
  mesher_.set_gate_min_atoms(11);  // big jobs wait at the gate, small ones pass
  mesher_.set_open(false);
  const http_reply big = post("/jobs", row_of_atoms(40));
  ASSERT_EQ(big.status, 202);
  const std::string big_id = nlohmann::json::parse(big.body).at("id");
  ASSERT_TRUE(eventually([&] { return service_->jobs().running_jobs() == 1; }));

  EXPECT_EQ(post("/mesh", gly_).status, 200) << "gly (7 atoms) ran on the small-job lane";
  const auto big_now = service_->jobs().find(big_id);
  ASSERT_TRUE(big_now);
  EXPECT_EQ(big_now->state, job_state::running) << "while the big job still holds the only general worker";
  mesher_.set_open(true);
  EXPECT_EQ(wait_job(big_id).value("status", ""), "done");
}

}  // namespace
}  // namespace tracemesh::server::test
