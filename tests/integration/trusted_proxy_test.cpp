// tracemeshd --trusted-proxy behind the real nginx (docker/nginx's configuration, support/nginx_process.hpp), with
// clients on two loopback addresses (127.0.0.2, 127.0.0.3): nginx appends each client's address to
// X-Forwarded-For, and tracemeshd counts per-client limits against it, so one client's full quota does not refuse
// the other; the access log names the client and the proxy.
#include <gtest/gtest.h>

#include <memory>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "support/eventually.hpp"
#include "support/nginx_process.hpp"
#include "support/test_http_client.hpp"
#include "support/test_paths.hpp"
#include "support/tracemeshd_process.hpp"

namespace {

using namespace std::chrono_literals;
using tracemesh::testing::eventually;
using tracemesh::testing::http_reply;
using tracemesh::testing::raw_connection;
using tracemesh::testing::read_file;
using tracemesh::testing::server_process;
using tracemesh::testing::temp_dir;

constexpr std::uint32_t first_client = 0x7f000002;   // 127.0.0.2
constexpr std::uint32_t second_client = 0x7f000003;  // 127.0.0.3

/// An upload of gly to POST /mesh.
std::string gly_upload() {
  return tracemesh::testing::upload_request("/mesh", read_file(tracemesh::testing::molecule_path("gly.pqr")));
}

http_reply upload_from(unsigned short port, std::uint32_t source) {
  raw_connection connection(port, 60s, 0, source);
  if (!connection.connected() || !connection.send(gly_upload())) return {};
  return connection.read_reply();
}

/// The access log lines of `route` in a tracemeshd log.
std::vector<nlohmann::json> access_lines(const std::string& log, const std::string& route) {
  std::vector<nlohmann::json> lines;
  std::istringstream in(log);
  std::string line;
  while (std::getline(in, line)) {
    const auto doc = nlohmann::json::parse(line, nullptr, false);
    if (!doc.is_discarded() && doc.value("event", "") == "access" && doc.value("route", "") == route) {
      lines.push_back(doc);
    }
  }
  return lines;
}

TEST(TrustedProxyTest, OneClientsFullUploadQuotaBehindNginxDoesNotRefuseAnother) {
  TRACEMESH_REQUIRE_NGINX();
  temp_dir work;
  server_process server(work.path(), {"--trusted-proxy", "127.0.0.1/32,::1", "--max-uploads-per-client", "1"});
  ASSERT_NE(server.port(), 0);
  // upload-replicas.conf names two replicas: both are this one.
  tracemesh::testing::nginx_process nginx(work.path() / "nginx", {server.port(), server.port()});
  ASSERT_NE(nginx.port(), 0);

  // The first client's upload in flight: its header and half its body (nginx streams it on unbuffered).
  const std::string upload = gly_upload();
  const std::size_t half = upload.find("\r\n\r\n") + 4 + (upload.size() - upload.find("\r\n\r\n")) / 2;
  raw_connection held(nginx.port(), 60s, 0, first_client);
  ASSERT_TRUE(held.send(upload.substr(0, half)));
  // Once tracemeshd holds it, the first client's next upload is over its quota...
  http_reply refused;
  ASSERT_TRUE(eventually([&] {
    refused = upload_from(nginx.port(), first_client);
    return refused.status == 429;
  })) << "the first client's second upload was never refused: " << refused.status << " " << refused.body;
  EXPECT_NE(refused.body.find("max_uploads_per_client"), std::string::npos) << refused.body;
  // ...and the second client's is not: before --trusted-proxy every request through nginx was nginx's.
  const http_reply other = upload_from(nginx.port(), second_client);
  EXPECT_EQ(other.status, 200) << other.body;

  ASSERT_TRUE(held.send(upload.substr(half)));
  EXPECT_EQ(held.read_reply().status, 200) << "the held upload completes";

  const std::vector<nlohmann::json> lines = access_lines(server.log(), "/mesh");
  bool first_seen = false, second_seen = false;
  for (const nlohmann::json& line : lines) {
    EXPECT_EQ(line.value("peer", ""), "127.0.0.1") << line.dump();
    first_seen = first_seen || line.value("client", "") == "127.0.0.2";
    second_seen = second_seen || line.value("client", "") == "127.0.0.3";
  }
  EXPECT_TRUE(first_seen && second_seen) << "the access log names both clients: " << server.log();
}

TEST(TrustedProxyTest, WithoutTrustXForwardedForIsIgnored) {
  temp_dir work;
  server_process server(work.path(), {"--max-uploads-per-client", "1"});
  ASSERT_NE(server.port(), 0);
  const std::string upload = gly_upload();
  const std::string forged_head = "X-Forwarded-For: 192.0.2.77\r\n";
  const std::size_t header_end = upload.find("\r\n\r\n") + 2;
  raw_connection held(server.port(), 60s);
  ASSERT_TRUE(held.send(upload.substr(0, header_end) + forged_head + "\r\n"));
  http_reply refused;
  ASSERT_TRUE(eventually([&] {
    raw_connection forged(server.port(), 60s);
    if (!forged.send(upload.substr(0, header_end) + "X-Forwarded-For: 192.0.2.78\r\n" +
                     upload.substr(header_end))) {
      return false;
    }
    refused = forged.read_reply();
    return refused.status == 429;
  })) << "a forged X-Forwarded-For named another client: " << refused.status << " " << refused.body;
  ASSERT_TRUE(held.send(upload.substr(header_end + 2)));
  EXPECT_EQ(held.read_reply().status, 200);
}

}  // namespace
