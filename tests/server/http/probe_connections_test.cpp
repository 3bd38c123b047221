// Probe connections (server/http/http_server.hpp, limits.health_connection_reserve) through a running service on a
// loopback port: a client over its connection limit, or one arriving at a full server, may still ask the health
// routes, and connections that never send a byte cannot take that away — from their own address or another.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test {
namespace {

constexpr std::uint32_t misbehaving_address = 0x7f000002;  // 127.0.0.2
constexpr std::uint32_t other_address = 0x7f000003;        // 127.0.0.3

class ProbeConnectionsTest : public service_fixture {
 protected:
  /// GET `target` on a fresh connection from `source`.
  http_reply get_from(std::uint32_t source, const std::string& target) {
    raw_connection connection(port_, 20s, 0, source);
    if (!connection.connected() || !connection.send(get_request(target))) return {};
    return connection.read_reply();
  }
  http_reply post_from(std::uint32_t source, const std::string& target, const std::string& pqr) {
    raw_connection connection(port_, 20s, 0, source);
    if (!connection.connected() || !connection.send(upload_request(target, pqr))) return {};
    return connection.read_reply();
  }
};

TEST_F(ProbeConnectionsTest, ThreeHundredSilentConnectionsFromOneAddressLeaveHealthAnsweredEverywhere) {
  start([](server_config& c) {
    // Silent probes are never closed by their deadline here: only giving way to a newer probe frees the reserve.
    c.limits.probe_header_timeout = std::chrono::minutes(10);
  });
  std::vector<std::unique_ptr<raw_connection>> silent;
  for (int i = 0; i < 300; ++i) {
    silent.push_back(std::make_unique<raw_connection>(port_, 20s, 0, misbehaving_address));
    ASSERT_TRUE(silent.back()->connected()) << i;
  }
  // The listener takes connections in order: the health checks below come after all 300.
  for (const char* target : {"/healthz", "/readyz"}) {
    const http_reply same = get_from(misbehaving_address, target);
    EXPECT_EQ(same.status, 200) << target << " from the address holding 300 silent connections: " << same.body;
    EXPECT_EQ(get_from(other_address, target).status, 200) << target << " from another address";
  }
  const http_reply refused = get_from(misbehaving_address, "/openapi.json");
  expect_error(refused, 429, "client_limit");
  const http_reply mesh = post_from(other_address, "/mesh", gly_);
  EXPECT_EQ(mesh.status, 200) << "another client is served: " << mesh.body;
  // The descriptor budget holds: the client's own limit plus the reserve, however many it opened.
  EXPECT_LE(service_->http_state().open_connections.load(),
            config_.limits.max_connections_per_client + config_.limits.health_connection_reserve + 1);
  EXPECT_LE(service_->http_state().probe_connections.load(), config_.limits.health_connection_reserve);
}

TEST_F(ProbeConnectionsTest, ASilentProbeIsClosedAtItsShortHeaderDeadline) {
  start([](server_config& c) {
    c.limits.max_connections_per_client = 1;
    c.limits.probe_header_timeout = 100ms;  // the normal header_timeout is a minute in these tests
  });
  raw_connection held(port_);
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 1; }));
  raw_connection probe(port_);
  EXPECT_TRUE(probe.closed_by_peer()) << "closed at probe_header_timeout";
  EXPECT_EQ(probe.unread(), "") << "without a response: it asked nothing";
  EXPECT_FALSE(held.closed_by_peer(200ms)) << "the connection within the client's limit waits its header_timeout";
}

TEST_F(ProbeConnectionsTest, AReserveFullOfBusyProbesRefusesANewOneUnread) {
  start([](server_config& c) {
    c.limits.max_connections_per_client = 1;
    c.limits.health_connection_reserve = 2;
    c.limits.probe_header_timeout = std::chrono::minutes(10);  // the busy probes wait as long as the test needs
  });
  raw_connection within_limit(port_, 20s, 0, misbehaving_address);
  // Two probes whose request has begun (never finished): busy, so neither can give way.
  raw_connection busy_1(port_, 20s, 0, misbehaving_address);
  raw_connection busy_2(port_, 20s, 0, misbehaving_address);
  ASSERT_TRUE(busy_1.send("GET /healthz HTTP/1.1\r\n"));
  ASSERT_TRUE(busy_2.send("GET /healthz HTTP/1.1\r\n"));
  ASSERT_TRUE(eventually([&] {
    return service_->http_state().probe_connections.load() == 2 && service_->http_state().probes.size() == 0;
  }));
  // The reserve is global: another client over its own limit finds it full, and is refused without being read.
  raw_connection other_within_limit(port_, 20s, 0, other_address);
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 4; }));
  raw_connection past(port_, 20s, 0, other_address);
  expect_error(past.read_reply(), 503, "unavailable");
  EXPECT_TRUE(past.closed_by_peer());
  ASSERT_TRUE(busy_1.send("Host: t\r\n\r\n"));
  EXPECT_EQ(busy_1.read_reply().status, 200) << "a busy probe is answered";
}

}  // namespace
}  // namespace tracemesh::server::test
