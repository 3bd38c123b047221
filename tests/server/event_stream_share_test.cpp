// A per-client share of the event streams (limits.max_event_streams_per_client) through a running service with the
// gated fake mesher: one address holding streams on its own running job leaves room for every other client, and
// its refusals are logged at warning level, once per client per refusal_log_interval.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include <spdlog/sinks/ringbuffer_sink.h>

#include "server/service_fixture.hpp"

namespace tracemesh::server::test {
namespace {

constexpr std::uint32_t greedy_address = 0x7f000002;  // 127.0.0.2
constexpr std::uint32_t other_address = 0x7f000003;   // 127.0.0.3

class EventStreamShareTest : public service_fixture {
 protected:
  /// The fixture's service, restarted with a logger whose last lines the test reads.
  void start_logged(const std::function<void(server_config&)>& adjust) {
    start(adjust);
    service_->shutdown();
    log_lines_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(10000);
    auto logger = std::make_shared<spdlog::logger>("test", log_lines_);
    logger->set_pattern(R"({"level":"%l",%v})");
    service_ = std::make_unique<service>(config_, logger, mesher_.function());
    ASSERT_TRUE(service_->start().ok());
    port_ = service_->port();
  }
  /// Log lines of `event` (at any level).
  std::vector<nlohmann::json> logged(const std::string& event) {
    std::vector<nlohmann::json> lines;
    for (const std::string& line : log_lines_->last_formatted()) {
      const auto doc = nlohmann::json::parse(line, nullptr, false);
      if (!doc.is_discarded() && doc.value("event", "") == event) lines.push_back(doc);
    }
    return lines;
  }
  /// An event stream of job `id` opened from `source`; its first event has arrived when it was accepted.
  std::unique_ptr<raw_connection> open_stream(std::uint32_t source, const std::string& id) {
    auto stream = std::make_unique<raw_connection>(port_, 20s, 0, source);
    EXPECT_TRUE(stream->send(get_request("/jobs/" + id + "/events")));
    return stream;
  }
  /// True once `stream` carries its first event (accepted), false when it was answered anything but 200.
  static bool accepted(raw_connection& stream) {
    const auto refused = [&] { return stream.unread().size() >= 12 && stream.unread().compare(9, 3, "200") != 0; };
    while (!stream.closed_by_peer(20ms) && !refused()) {
      if (stream.unread().find("event: progress") != std::string::npos) return true;
    }
    return stream.unread().find("event: progress") != std::string::npos;
  }

  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> log_lines_;
};

TEST_F(EventStreamShareTest, OneAddressesStreamsOnItsRunningJobLeaveRoomForOtherClients) {
  start_logged([](server_config& c) {
    c.limits.max_event_streams = 4;
    c.limits.max_event_streams_per_client = 2;
  });
  mesher_.set_open(false);
  raw_connection submitter(port_, 20s, 0, greedy_address);
  ASSERT_TRUE(submitter.send(upload_request("/jobs", gly_)));
  const http_reply submitted = submitter.read_reply();
  ASSERT_EQ(submitted.status, 202) << submitted.body;
  const std::string id = nlohmann::json::parse(submitted.body).at("id");
  ASSERT_TRUE(eventually([&] { return service_->jobs().running_jobs() == 1; }));

  // The greedy client asks for every stream the server has: it gets its share.
  std::vector<std::unique_ptr<raw_connection>> greedy;
  for (int i = 0; i < 2; ++i) {
    greedy.push_back(open_stream(greedy_address, id));
    ASSERT_TRUE(accepted(*greedy.back())) << i << ": " << greedy.back()->unread();
  }
  for (int i = 0; i < 2; ++i) {
    raw_connection refused(port_, 20s, 0, greedy_address);
    ASSERT_TRUE(refused.send(get_request("/jobs/" + id + "/events")));
    const http_reply r = refused.read_reply();
    expect_error(r, 429, "client_limit");
    EXPECT_EQ(r.header("retry-after"), std::to_string(config_.limits.retry_after_seconds));
    EXPECT_NE(r.body.find("max_event_streams_per_client"), std::string::npos) << r.body;
  }
  // Everyone else still gets a stream (before the per-client share, the fourth greedy stream took the last one).
  const auto other = open_stream(other_address, id);
  EXPECT_TRUE(accepted(*other)) << other->unread();
  const auto another = open_stream(INADDR_LOOPBACK, id);
  EXPECT_TRUE(accepted(*another)) << another->unread();

  // Two refusals of one client within the interval: one warning, no error line.
  const std::vector<nlohmann::json> warnings = logged("client_limit_refused");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].value("level", ""), "warning");
  EXPECT_EQ(warnings[0].value("client", ""), "ip:127.0.0.2");
  EXPECT_EQ(warnings[0].value("limit", ""), "max_event_streams_per_client");
  for (const std::string& line : log_lines_->last_formatted()) {
    EXPECT_EQ(line.find("\"level\":\"error\""), std::string::npos) << line;
  }

  mesher_.set_open(true);
  for (auto& stream : greedy) EXPECT_TRUE(stream->closed_by_peer());
  EXPECT_TRUE(eventually([&] { return service_->http_state().event_streams.load() == 0; }));
}

}  // namespace
}  // namespace tracemesh::server::test
