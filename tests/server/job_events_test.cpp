// GET /jobs/{id}/events (Server-Sent Events) through a running service with the gated fake mesher: the contract
// (progress at connect and on change, one final done/error event, then the server closes), 404/400, the stream
// limit, a client that leaves, and the connection limit's idle eviction sparing active streams.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/service_fixture.hpp"
#include "support/event_stream.hpp"

namespace tracemesh::server::test {
namespace {

using tracemesh::testing::parse_raw_event_stream;
using tracemesh::testing::raw_event_stream;

class JobEventsTest : public service_fixture {
 protected:
  /// POST /jobs of gly; its id (the fake mesher holds it running until mesher_.set_open(true)).
  std::string submit_held_job() {
    mesher_.set_open(false);
    const http_reply accepted = post("/jobs", gly_);
    EXPECT_EQ(accepted.status, 202) << accepted.body;
    accepted_ = accepted;
    const std::string id = nlohmann::json::parse(accepted.body).at("id");
    EXPECT_TRUE(eventually([&] { return service_->jobs().running_jobs() == 1; }));
    return id;
  }

  /// Reads from `stream` until its bytes hold `count` events (or the stream closed, or `within` passed: a bound
  /// on how long a failing test takes); the stream so far.
  raw_event_stream read_events(raw_connection& stream, std::size_t count, std::chrono::milliseconds within = 120s) {
    const auto deadline = std::chrono::steady_clock::now() + within;
    raw_event_stream parsed = parse_raw_event_stream(stream.unread());
    while (parsed.events.size() < count && std::chrono::steady_clock::now() < deadline) {
      if (stream.closed_by_peer(20ms)) {
        parsed = parse_raw_event_stream(stream.unread());
        break;
      }
      parsed = parse_raw_event_stream(stream.unread());
    }
    return parsed;
  }

  /// Checks the contract on a complete stream: progress events first (progress never decreasing), exactly one
  /// final event last, named `final_name`; returns the final event's job document.
  nlohmann::json expect_contract(const raw_event_stream& stream, const std::string& final_name) {
    EXPECT_EQ(stream.headers.at(":status"), "200");
    EXPECT_EQ(stream.headers.count("content-type") ? stream.headers.at("content-type") : "", "text/event-stream");
    EXPECT_EQ(stream.headers.count("cache-control") ? stream.headers.at("cache-control") : "", "no-store");
    if (stream.events.empty()) {
      ADD_FAILURE() << "no events";
      return {};
    }
    double progress = 0;
    for (std::size_t i = 0; i + 1 < stream.events.size(); ++i) {
      EXPECT_EQ(stream.events[i].name, "progress") << i;
      const auto doc = nlohmann::json::parse(stream.events[i].data);
      EXPECT_GE(doc.at("progress").get<double>(), progress) << "progress went backwards at event " << i;
      progress = doc.at("progress");
      EXPECT_TRUE(doc.contains("eta_s"));
    }
    EXPECT_EQ(stream.events.front().name, "progress") << "one progress event at connect";
    EXPECT_EQ(stream.events.back().name, final_name);
    return nlohmann::json::parse(stream.events.back().data);
  }

  http_reply accepted_;
};

TEST_F(JobEventsTest, StreamsProgressThenOneDoneEventEqualToGetJobAndCloses) {
  start();
  const std::string id = submit_held_job();
  raw_connection stream(port_);
  ASSERT_TRUE(stream.send(get_request("/jobs/" + id + "/events")));
  raw_event_stream so_far = read_events(stream, 1);
  ASSERT_EQ(so_far.events.size(), 1u) << stream.unread();
  EXPECT_EQ(so_far.events[0].name, "progress");
  EXPECT_EQ(nlohmann::json::parse(so_far.events[0].data).at("status"), "running");
  ASSERT_EQ(so_far.headers.count("transfer-encoding"), 1u);
  EXPECT_EQ(so_far.headers.at("transfer-encoding"), "chunked");
  // Nothing changes while the mesher is held: no further event (progress is sent on change only).
  EXPECT_FALSE(stream.closed_by_peer(700ms));
  EXPECT_EQ(parse_raw_event_stream(stream.unread()).events.size(), 1u) << stream.unread();

  mesher_.set_open(true);
  EXPECT_TRUE(stream.closed_by_peer()) << "the server closes the stream after the final event";
  const nlohmann::json final_doc = expect_contract(parse_raw_event_stream(stream.unread()), "done");
  EXPECT_EQ(final_doc.at("status"), "done");
  EXPECT_EQ(final_doc.at("eta_s"), 0.0);
  const http_reply polled = get("/jobs/" + id);
  ASSERT_EQ(polled.status, 200);
  EXPECT_EQ(final_doc, nlohmann::json::parse(polled.body));
  EXPECT_TRUE(eventually([&] { return service_->http_state().event_streams.load() == 0; }));
}

TEST_F(JobEventsTest, AJobAlreadyDoneGetsItsDoneEventAtOnce) {
  start();
  mesher_.set_open(true);
  const http_reply accepted = post("/jobs", gly_);
  const std::string id = nlohmann::json::parse(accepted.body).at("id");
  ASSERT_EQ(wait_job(id).at("status"), "done");
  raw_connection stream(port_);
  ASSERT_TRUE(stream.send(get_request("/jobs/" + id + "/events")));
  EXPECT_TRUE(stream.closed_by_peer());
  const raw_event_stream events = parse_raw_event_stream(stream.unread());
  EXPECT_EQ(events.events.size(), 2u) << stream.unread();
  EXPECT_EQ(expect_contract(events, "done"), nlohmann::json::parse(get("/jobs/" + id).body));
}

TEST_F(JobEventsTest, AnHttp10ClientGetsTheEventsCloseDelimited) {
  start();
  mesher_.set_open(true);
  const std::string id = nlohmann::json::parse(post("/jobs", gly_).body).at("id");
  ASSERT_EQ(wait_job(id).at("status"), "done");
  raw_connection stream(port_);
  ASSERT_TRUE(stream.send("GET /jobs/" + id + "/events HTTP/1.0\r\n\r\n"));
  EXPECT_TRUE(stream.closed_by_peer());
  const raw_event_stream events = parse_raw_event_stream(stream.unread());
  EXPECT_EQ(events.headers.count("transfer-encoding"), 0u) << "HTTP/1.0 has no chunked coding";
  ASSERT_EQ(events.events.size(), 2u) << stream.unread();
  EXPECT_EQ(expect_contract(events, "done"), nlohmann::json::parse(get("/jobs/" + id).body));
}

TEST_F(JobEventsTest, ACancelledJobEndsWithAnErrorEvent) {
  start();
  const std::string id = submit_held_job();
  raw_connection stream(port_);
  ASSERT_TRUE(stream.send(get_request("/jobs/" + id + "/events")));
  ASSERT_EQ(read_events(stream, 1).events.size(), 1u);
  ASSERT_EQ(withdraw(accepted_).status, 200);
  EXPECT_TRUE(stream.closed_by_peer());
  const nlohmann::json final_doc = expect_contract(parse_raw_event_stream(stream.unread()), "error");
  EXPECT_EQ(final_doc.at("status"), "cancelled");
  EXPECT_EQ(final_doc.at("error").at("code"), "cancelled");
  EXPECT_TRUE(final_doc.at("eta_s").is_null());
}

TEST_F(JobEventsTest, UnknownAndMalformedIdsAreJsonErrors) {
  start();
  expect_error(get("/jobs/" + std::string(64, 'a') + "/events"), 404, "not_found");
  expect_error(get("/jobs/nothex/events"), 400, "invalid_argument");
  expect_error(request("POST", "/jobs/" + std::string(64, 'a') + "/events"), 405, "method_not_allowed");
  expect_error(get("/jobs/" + std::string(64, 'a') + "/events?x=1"), 400, "invalid_argument");
}

TEST_F(JobEventsTest, StreamsPastTheLimitGet503AndALeavingClientFreesItsSlot) {
  start([](server_config& c) { c.limits.max_event_streams = 1; });
  const std::string id = submit_held_job();
  auto first = std::make_unique<raw_connection>(port_);
  ASSERT_TRUE(first->send(get_request("/jobs/" + id + "/events")));
  ASSERT_EQ(read_events(*first, 1).events.size(), 1u);
  const http_reply refused = get("/jobs/" + id + "/events");
  expect_error(refused, 503, "unavailable");
  EXPECT_FALSE(refused.header("retry-after").empty());

  first->close();  // the server notices the client leaving while the job still runs
  ASSERT_TRUE(eventually([&] { return service_->http_state().event_streams.load() == 0; }));
  ASSERT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 0; }));
  raw_connection second(port_);
  ASSERT_TRUE(second.send(get_request("/jobs/" + id + "/events")));
  EXPECT_EQ(read_events(second, 1).events.size(), 1u) << "the slot is free again";
}

TEST_F(JobEventsTest, IdleEvictionAtTheConnectionLimitSparesActiveStreams) {
  start([](server_config& c) { c.limits.max_connections = 2; });
  const std::string id = submit_held_job();
  raw_connection stream(port_);
  ASSERT_TRUE(stream.send(get_request("/jobs/" + id + "/events")));
  ASSERT_EQ(read_events(stream, 1).events.size(), 1u);
  // The submission's connection is gone once the server has seen its client close it.
  EXPECT_TRUE(eventually([&] { return service_->http_state().open_connections.load() == 1; }))
      << "a stream holds a connection";

  // The second slot: an idle keep-alive connection. Each newcomer over the limit closes the idle one, never the
  // stream, although the stream is the oldest connection.
  std::vector<std::unique_ptr<raw_connection>> others;
  for (int round = 0; round < 3; ++round) {
    others.push_back(std::make_unique<raw_connection>(port_));
    ASSERT_TRUE(others.back()->send(get_request("/healthz")));
    ASSERT_EQ(others.back()->read_reply().status, 200) << round;
    if (round > 0) {
      EXPECT_TRUE(others[round - 1]->closed_by_peer()) << "the idle one gives way: " << round;
    }
    // The answered connection is idle once the server has filed it so (just after the answer): only then is there
    // an idle connection for the next newcomer to close (else that one waits for a slot until some timeout).
    ASSERT_TRUE(eventually([&] { return service_->http_state().idle.size() == 1; })) << round;
  }
  EXPECT_FALSE(stream.closed_by_peer(300ms)) << "the stream is busy, not idle";
  mesher_.set_open(true);
  EXPECT_TRUE(stream.closed_by_peer());
  expect_contract(parse_raw_event_stream(stream.unread()), "done");
}

TEST_F(JobEventsTest, EtaIsNullWhileQueuedAndZeroWhenDone) {
  start([](server_config& c) { c.small_job_workers = 0; });  // else the small-job lane runs the second job at once
  const std::string id = submit_held_job();
  const http_reply second = post("/jobs", gly_, {{"density", "2"}});
  ASSERT_EQ(second.status, 202);
  const std::string queued_id = nlohmann::json::parse(second.body).at("id");
  const auto queued = nlohmann::json::parse(get("/jobs/" + queued_id).body);
  EXPECT_EQ(queued.at("status"), "queued");
  EXPECT_TRUE(queued.at("eta_s").is_null());
  mesher_.set_open(true);
  EXPECT_EQ(wait_job(queued_id).at("eta_s"), 0.0);
  EXPECT_EQ(wait_job(id).at("eta_s"), 0.0);
}

}  // namespace
}  // namespace tracemesh::server::test
