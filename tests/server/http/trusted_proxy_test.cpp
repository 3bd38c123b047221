// --trusted-proxy (limits.trusted_proxies, server/admission/forwarded_client.hpp) through a running service on a
// loopback port: requests a trusted proxy forwards count against the client its header names, for uploads and for
// connections; from any other peer the headers change nothing; a header that cannot be read falls back to the
// proxy's address, never to an error. The same through the real nginx: tests/integration/trusted_proxy_test.cpp.
#include <gtest/gtest.h>

#include <string>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test {
namespace {

constexpr std::uint32_t proxy_address = 0x7f000001;    // 127.0.0.1, trusted
constexpr std::uint32_t untrusted_address = 0x7f000002;  // 127.0.0.2

class TrustedProxyTest : public service_fixture {
 protected:
  void start_behind_proxy(const std::function<void(server_config&)>& adjust) {
    start([&](server_config& c) {
      c.limits.trusted_proxies = *parse_networks({"127.0.0.1/32"});
      adjust(c);
    });
  }
  static std::string header_of(const std::string& request) { return request.substr(0, request.find("\r\n\r\n") + 4); }
  /// An upload from `source` with `headers`, its header sent and its body held back (an upload in flight).
  std::unique_ptr<raw_connection> hold_upload(std::uint32_t source, const std::string& headers) {
    auto connection = std::make_unique<raw_connection>(port_, 20s, 0, source);
    EXPECT_TRUE(connection->send(header_of(upload_request("/mesh", gly_, {}, headers))));
    return connection;
  }
  http_reply upload_from(std::uint32_t source, const std::string& headers) {
    raw_connection connection(port_, 20s, 0, source);
    if (!connection.send(upload_request("/mesh", gly_, {}, headers))) return {};
    return connection.read_reply();
  }
  static std::string message_of(const http_reply& r) {
    const auto doc = nlohmann::json::parse(r.body, nullptr, false);
    return doc.is_discarded() ? std::string() : doc["error"].value("message", "");
  }
};

TEST_F(TrustedProxyTest, UploadsThroughATrustedProxyCountAgainstTheForwardedClient) {
  start_behind_proxy([](server_config& c) { c.limits.max_uploads_per_client = 1; });
  const auto held = hold_upload(proxy_address, "X-Forwarded-For: 192.0.2.1\r\n");
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 1; }));

  const http_reply refused = upload_from(proxy_address, "X-Forwarded-For: 6.6.6.6, 192.0.2.1\r\n");
  expect_error(refused, 429, "client_limit");
  EXPECT_NE(message_of(refused).find("max_uploads_per_client"), std::string::npos) << refused.body;
  EXPECT_EQ(upload_from(proxy_address, "X-Forwarded-For: 192.0.2.2\r\n").status, 200) << "another client uploads";
  EXPECT_EQ(upload_from(proxy_address, "Forwarded: for=\"[2001:db8::2]:4711\";proto=http\r\n").status, 200);
  EXPECT_EQ(upload_from(proxy_address, "").status, 200) << "the proxy's own request is the proxy's";
}

TEST_F(TrustedProxyTest, HeadersFromAnUntrustedPeerAndUnreadableHeadersChangeNothing) {
  start_behind_proxy([](server_config& c) { c.limits.max_uploads_per_client = 1; });
  const auto untrusted = hold_upload(untrusted_address, "X-Forwarded-For: 192.0.2.9\r\n");
  const auto unreadable = hold_upload(proxy_address, "X-Forwarded-For: garbage\r\n");
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 2; }));

  // Both count against their peer: 127.0.0.2 (headers ignored) and the proxy itself (header unreadable).
  expect_error(upload_from(untrusted_address, "X-Forwarded-For: 192.0.2.10\r\n"), 429, "client_limit");
  for (const char* header : {"Forwarded: for=unknown\r\n", "Forwarded: for=\"[2001:db8::1\r\n",
                             "X-Forwarded-For: 192.0.2.5,\r\n", ""}) {
    expect_error(upload_from(proxy_address, header), 429, "client_limit");
  }
  EXPECT_EQ(upload_from(proxy_address, "X-Forwarded-For: 192.0.2.10\r\n").status, 200);
}

TEST_F(TrustedProxyTest, AProxysConnectionsCountAgainstTheClientOfTheRequestTheyCarry) {
  start_behind_proxy([](server_config& c) { c.limits.max_connections_per_client = 1; });
  // More proxy connections than one client may hold: the proxy itself is not a client.
  raw_connection idle_1(port_), idle_2(port_);
  const auto held = hold_upload(proxy_address, "X-Forwarded-For: 192.0.2.1\r\n");
  ASSERT_TRUE(eventually([&] { return service_->uploads().uploads_in_flight() == 1; }));

  const std::string missing_job = "/jobs/" + std::string(64, '0');
  ASSERT_TRUE(idle_1.send(get_request(missing_job, "X-Forwarded-For: 192.0.2.1\r\n")));
  const http_reply refused = idle_1.read_reply();
  expect_error(refused, 429, "client_limit");
  EXPECT_NE(message_of(refused).find("max_connections_per_client"), std::string::npos) << refused.body;
  ASSERT_TRUE(idle_2.send(get_request("/healthz", "X-Forwarded-For: 192.0.2.1\r\n")));
  EXPECT_EQ(idle_2.read_reply().status, 200) << "health routes answer over the limit";

  raw_connection other(port_);
  ASSERT_TRUE(other.send(get_request(missing_job, "X-Forwarded-For: 192.0.2.2\r\n")));
  EXPECT_EQ(other.read_reply().status, 404) << "another client's request on a proxy connection is served";
  ASSERT_TRUE(other.send(get_request(missing_job, "X-Forwarded-For: 192.0.2.3\r\n")));
  EXPECT_EQ(other.read_reply().status, 404) << "an answered request gives its client's count back";
}

}  // namespace
}  // namespace tracemesh::server::test
