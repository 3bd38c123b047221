// Protocol corners through the real HTTP server: CORS preflight headers, empty lines before a request line,
// OPTIONS *, Host validation, If-Match, X-Content-Type-Options on every response, the default format of a job's
// mesh after a restart, and DELETE answering the same for the same final state.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test::protocol_corners {

class ProtocolCorners : public service_fixture {
 protected:
  using fields_type = std::vector<std::pair<std::string, std::string>>;

  /// POST /jobs of gly.pqr with `fields`, waited until done; its id.
  std::string done_job(const fields_type& fields = {}) {
    const http_reply accepted = post("/jobs", gly_, fields);
    EXPECT_TRUE(accepted.status == 202 || accepted.status == 200) << accepted.body;
    const std::string id = nlohmann::json::parse(accepted.body).at("id");
    EXPECT_EQ(wait_job(id).at("status"), "done");
    return id;
  }
};

TEST_F(ProtocolCorners, APreflightAllowsTheAuthorizationAndJobTokenHeaders) {
  start();
  const http_reply preflight =
      request("OPTIONS", "/jobs/" + std::string(64, 'a'),
              "Origin: https://lab.example.org\r\nAccess-Control-Request-Method: DELETE\r\n"
              "Access-Control-Request-Headers: authorization, x-job-token\r\n");
  EXPECT_EQ(preflight.status, 204);
  const std::string allowed = preflight.header("access-control-allow-headers");
  EXPECT_NE(allowed.find("Authorization"), std::string::npos) << allowed;
  EXPECT_NE(allowed.find("X-Job-Token"), std::string::npos) << allowed;
  EXPECT_NE(preflight.header("access-control-allow-methods").find("DELETE"), std::string::npos);
}

TEST_F(ProtocolCorners, EmptyLinesBeforeARequestLineAreIgnored) {
  start();
  EXPECT_EQ(round_trip(port_, "\r\n" + get_request("/healthz")).status, 200);
  EXPECT_EQ(round_trip(port_, "\r\n\r\n\n" + get_request("/healthz")).status, 200);
  // Between two requests on one connection, as a client that ends a body with an extra CRLF sends them.
  raw_connection connection(port_);
  ASSERT_TRUE(connection.send(get_request("/healthz") + "\r\n" + get_request("/readyz")));
  EXPECT_EQ(connection.read_reply().status, 200);
  const http_reply second = connection.read_reply();
  EXPECT_EQ(second.status, 200);
  EXPECT_NE(second.body.find("ready"), std::string::npos) << second.body;
  // The empty line arriving alone, the request after it.
  raw_connection split(port_);
  ASSERT_TRUE(split.send("\r\n"));
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() >= 1; }));
  ASSERT_TRUE(split.send(get_request("/healthz")));
  EXPECT_EQ(split.read_reply().status, 200);
}

TEST_F(ProtocolCorners, OptionsStarIsAnswered) {
  start();
  const http_reply reply = round_trip(port_, "OPTIONS * HTTP/1.1\r\nHost: test\r\n\r\n");
  EXPECT_EQ(reply.status, 204);
  EXPECT_EQ(reply.header("allow"), "GET, HEAD, POST, DELETE, OPTIONS");
  expect_error(round_trip(port_, "GET * HTTP/1.1\r\nHost: test\r\n\r\n"), 400, "bad_request");
}

TEST_F(ProtocolCorners, AnInvalidHostIs400) {
  start();
  for (const char* host : {"exa mple", "a/b", "user@host", "host:80a", "[::1", "[zz]:1", "ho\"st"}) {
    expect_error(round_trip(port_, "GET /healthz HTTP/1.1\r\nHost: " + std::string(host) + "\r\n\r\n"), 400,
                 "bad_request");
  }
  for (const char* host : {"localhost", "localhost:8080", "127.0.0.1:1", "[::1]:8080", "[::1]", "my-host.example",
                           "xn--bcher-kva.example", ""}) {
    EXPECT_EQ(round_trip(port_, "GET /healthz HTTP/1.1\r\nHost: " + std::string(host) + "\r\n\r\n").status, 200)
        << host;
  }
}

TEST_F(ProtocolCorners, IfMatchThatMatchesNothingIs412) {
  start();
  const std::string id = done_job();
  const std::string url = "/jobs/" + id + "/mesh?format=off";
  const http_reply plain = get(url);
  ASSERT_EQ(plain.status, 200);
  const std::string etag = plain.header("etag");
  const http_reply refused = get(url, "If-Match: \"another\"\r\n");
  expect_error(refused, 412, "precondition_failed");
  EXPECT_EQ(refused.header("etag"), etag);
  expect_error(get(url, "If-Match: W/" + etag + "\r\n"), 412, "precondition_failed");  // strong comparison
  EXPECT_EQ(get(url, "If-Match: \"x\", " + etag + "\r\n").status, 200);
  EXPECT_EQ(get(url, "If-Match: *\r\n").status, 200);
  const http_reply page = get("/");
  ASSERT_EQ(page.status, 200);
  expect_error(get("/", "If-Match: \"stale\"\r\n"), 412, "precondition_failed");
  EXPECT_EQ(get("/", "If-Match: " + page.header("etag") + "\r\n").status, 200);
}

TEST_F(ProtocolCorners, EveryResponseSaysNosniff) {
  start();
  const http_reply mesh = post("/mesh", gly_);
  ASSERT_EQ(mesh.status, 200);
  const std::string id = done_job({{"format", "ply"}});
  const http_reply replies[] = {
      get("/healthz"),
      mesh,
      get("/jobs/" + id + "/mesh?format=ply"),
      get("/jobs/" + id),
      get("/"),
      get("/openapi.json"),
      get("/metrics"),
      get("/nowhere"),
      request("OPTIONS", "/mesh"),
      post("/mesh", "not a molecule"),
      round_trip(port_, "GET /healthz HTTP/1.1\r\n\r\n"),  // 400 before any route
  };
  for (const http_reply& reply : replies) {
    EXPECT_NE(reply.status, 0);
    EXPECT_EQ(reply.header("x-content-type-options"), "nosniff") << reply.status << " " << reply.body.substr(0, 80);
  }
}

TEST_F(ProtocolCorners, AfterARestartTheMeshDefaultsToTheFormatTheJobWasSubmittedWith) {
  const auto dir = std::filesystem::temp_directory_path() / ("tracemesh-corners-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const auto on_disk = [&](server_config& c) {
    c.cache_dir = dir;
    c.job_dir = dir / "jobs";
  };
  start(on_disk);
  const std::string id = done_job({{"format", "ply"}});
  EXPECT_EQ(get("/jobs/" + id + "/mesh").header("content-type"), "model/x-ply");
  service_->shutdown();
  service_.reset();
  start(on_disk);
  const http_reply status = get("/jobs/" + id);
  ASSERT_EQ(status.status, 200);
  EXPECT_EQ(nlohmann::json::parse(status.body).at("links").at("mesh"), "/jobs/" + id + "/mesh?format=ply");
  const http_reply mesh = get("/jobs/" + id + "/mesh");
  EXPECT_EQ(mesh.status, 200) << mesh.body;
  EXPECT_EQ(mesh.header("content-type"), "model/x-ply") << "the record's format, the one links.mesh names";
  EXPECT_EQ(mesh.body, get("/jobs/" + id + "/mesh?format=ply").body);
  service_->shutdown();
  std::filesystem::remove_all(dir);
}

TEST_F(ProtocolCorners, DeleteAnswersTheSameForTheSameFinalState) {
  start();
  // Done: 409, the same every time, whatever the token.
  const http_reply accepted = post("/jobs", gly_);
  ASSERT_EQ(accepted.status, 202);
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  ASSERT_EQ(wait_job(id).at("status"), "done");
  const http_reply first = withdraw(accepted);
  expect_error(first, 409, "conflict");
  for (const std::string& token : {nlohmann::json::parse(accepted.body).at("token").get<std::string>(),
                                  std::string("another")}) {
    const http_reply again = request("DELETE", "/jobs/" + id, "X-Job-Token: " + token + "\r\n");
    EXPECT_EQ(again.status, first.status);
    EXPECT_EQ(again.body, first.body);
  }
  // Cancelled: 200 with the same document every time, whatever the token.
  mesher_.set_open(false);
  const http_reply held = post("/jobs", atom_line(1, 0.0));
  ASSERT_EQ(held.status, 202);
  const std::string held_id = nlohmann::json::parse(held.body).at("id");
  ASSERT_TRUE(eventually([&] { return mesher_.runs() == 2; }));
  EXPECT_EQ(withdraw(held).status, 200);
  ASSERT_EQ(wait_job(held_id).at("status"), "cancelled");
  const http_reply cancelled = withdraw(held);
  EXPECT_EQ(cancelled.status, 200);
  const http_reply by_other = request("DELETE", "/jobs/" + held_id, "X-Job-Token: another\r\n");
  EXPECT_EQ(by_other.status, 200) << by_other.body;
  EXPECT_EQ(by_other.body, cancelled.body);
}

}  // namespace tracemesh::server::test::protocol_corners
