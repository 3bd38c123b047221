// The Redis client against a real redis-server on a loopback port (tests/support/redis_process.hpp).
#include "server/redis/redis_client.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "support/eventually.hpp"
#include "support/redis_process.hpp"

namespace tracemesh::server {
namespace {

using namespace std::chrono_literals;
using testing::free_loopback_port;
using testing::redis_process;

/// Short timeouts and backoff, so the reconnect tests take milliseconds.
redis_limits quick_limits() {
  redis_limits limits;
  limits.connect_timeout = 500ms;
  limits.command_timeout = 2s;
  limits.reconnect_backoff_initial = 5ms;
  limits.reconnect_backoff_max = 40ms;
  return limits;
}

/// Runs `arguments` until it succeeds (the client reconnecting after its backoff; tracemesh::testing::eventually).
result<redis_reply> command_until_ok(redis_client& client, const std::vector<std::string>& arguments) {
  result<redis_reply> reply = client.command(arguments);
  tracemesh::testing::eventually([&] { return (reply = client.command(arguments)).ok(); });
  return reply;
}

class RedisClient : public ::testing::Test {
 protected:
  void SetUp() override {
    TRACEMESH_REQUIRE_REDIS_SERVER();
    ASSERT_TRUE(redis_.start());
  }
  redis_process redis_;
};

TEST_F(RedisClient, ConnectsAndRunsCommands) {
  redis_client client(redis_.endpoint(), quick_limits());
  EXPECT_FALSE(client.connected());  // lazily: the constructor does not connect
  ASSERT_TRUE(client.connect().ok());
  EXPECT_TRUE(client.connected());

  const auto set = client.command({"SET", "job:abc", "queued"});
  ASSERT_TRUE(set.ok()) << set.error().message();
  EXPECT_TRUE(set->is_status("OK"));
  const auto get = client.command({"GET", "job:abc"});
  ASSERT_TRUE(get.ok());
  EXPECT_EQ(get->type, redis_reply::kind::string);
  EXPECT_EQ(get->text, "queued");
  const auto missing = client.command({"GET", "job:none"});
  ASSERT_TRUE(missing.ok());
  EXPECT_TRUE(missing->is_nil());
  const auto counter = client.command({"INCRBY", "n", "41"});
  ASSERT_TRUE(counter.ok());
  EXPECT_EQ(counter->type, redis_reply::kind::integer);
  EXPECT_EQ(counter->integer, 41);
  EXPECT_EQ(client.stats().connects, 1u);
}

TEST_F(RedisClient, ArgumentsAreBinarySafe) {
  redis_client client(redis_.endpoint(), quick_limits());
  const std::string bytes("a\0b\r\n c\xff", 8);
  ASSERT_TRUE(client.command({"SET", bytes, bytes}).ok());
  const auto get = client.command({"GET", bytes});
  ASSERT_TRUE(get.ok());
  EXPECT_EQ(get->text, bytes);
}

TEST_F(RedisClient, ArraysAndErrorRepliesAreValues) {
  redis_client client(redis_.endpoint(), quick_limits());
  ASSERT_TRUE(client.command({"HSET", "job:1", "status", "running", "progress", "0.25"}).ok());
  const auto all = client.command({"HGETALL", "job:1"});
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->type, redis_reply::kind::array);
  ASSERT_EQ(all->elements.size(), 4u);
  EXPECT_EQ(all->elements[0].text, "status");
  EXPECT_EQ(all->elements[1].text, "running");

  // A Redis error reply is a successful round trip: the caller judges it; the connection stays usable.
  const auto wrong_type = client.command({"INCR", "job:1"});
  ASSERT_TRUE(wrong_type.ok());
  EXPECT_TRUE(wrong_type->is_error());
  EXPECT_EQ(wrong_type->text.rfind("WRONGTYPE", 0), 0u) << wrong_type->text;
  const auto unknown = client.command({"NO_SUCH_COMMAND"});
  ASSERT_TRUE(unknown.ok());
  EXPECT_TRUE(unknown->is_error());
  EXPECT_TRUE(client.command({"PING"})->is_status("PONG"));
  EXPECT_EQ(client.stats().connects, 1u);

  const auto empty = client.command({});
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code(), errc::invalid_argument);
}

TEST_F(RedisClient, PipelineAnswersInOrder) {
  redis_client client(redis_.endpoint(), quick_limits());
  const auto replies = client.pipeline({{"RPUSH", "q", "a", "b"}, {"LPOP", "q"}, {"LLEN", "q"}, {"GET", "none"}});
  ASSERT_TRUE(replies.ok()) << replies.error().message();
  ASSERT_EQ(replies->size(), 4u);
  EXPECT_EQ((*replies)[0].integer, 2);
  EXPECT_EQ((*replies)[1].text, "a");
  EXPECT_EQ((*replies)[2].integer, 1);
  EXPECT_TRUE((*replies)[3].is_nil());
}

TEST_F(RedisClient, SelectsTheDatabaseOfTheUrl) {
  redis_client db0(redis_.endpoint(0), quick_limits());
  redis_client db2(redis_.endpoint(2), quick_limits());
  ASSERT_TRUE(db2.command({"SET", "where", "two"}).ok());
  EXPECT_TRUE(db0.command({"GET", "where"})->is_nil());
  EXPECT_EQ(db2.command({"GET", "where"})->text, "two");

  // An index this server does not have (16 databases by default) fails at connect, with Redis's reason.
  redis_client db99(redis_.endpoint(99), quick_limits());
  const status refused = db99.connect();
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.code(), errc::io_error);
  EXPECT_NE(refused.message().find("SELECT"), std::string::npos) << refused.message();
}

TEST_F(RedisClient, ReconnectsAfterRedisIsRestarted) {
  redis_client client(redis_.endpoint(), quick_limits());
  ASSERT_TRUE(client.command({"SET", "before", "1"}).ok());

  redis_.stop();
  // The old connection is dead: the command fails as a value naming the endpoint; then the backoff window
  // refuses at once (without touching the network) until the next attempt.
  const auto lost = client.command({"GET", "before"});
  ASSERT_FALSE(lost.ok());
  EXPECT_EQ(lost.error().code(), errc::io_error);
  EXPECT_NE(lost.error().message().find(redis_.url()), std::string::npos) << lost.error().message();
  EXPECT_FALSE(client.connected());

  ASSERT_TRUE(redis_.restart());
  const auto after = command_until_ok(client, {"SET", "after", "2"});
  ASSERT_TRUE(after.ok()) << after.error().message();
  EXPECT_TRUE(client.connected());
  EXPECT_EQ(client.command({"GET", "after"})->text, "2");
  EXPECT_TRUE(client.command({"GET", "before"})->is_nil());  // the restarted server persisted nothing
  EXPECT_EQ(client.stats().connects, 2u);
  EXPECT_GE(client.stats().failed_commands, 1u);
}

TEST_F(RedisClient, BackoffRefusesAtOnceWhileRedisIsDown) {
  redis_limits limits = quick_limits();
  limits.reconnect_backoff_initial = 60s;  // one failure closes the window for the rest of the test
  limits.reconnect_backoff_max = 60s;
  redis_client client(redis_.endpoint(), limits);
  ASSERT_TRUE(client.connect().ok());
  redis_.stop();
  ASSERT_FALSE(client.command({"PING"}).ok());
  ASSERT_TRUE(redis_.restart());

  // Redis is back, but the window is still closed: commands are refused without a connection attempt...
  const auto refused = client.command({"PING"});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message().find("backoff"), std::string::npos) << refused.error().message();
  EXPECT_EQ(client.stats().backoff_rejections, 1u);
  EXPECT_EQ(client.stats().connects, 1u);
  // ...while connect() (the start-up and readiness check) always really tries.
  ASSERT_TRUE(client.connect().ok());
  EXPECT_TRUE(client.command({"PING"})->is_status("PONG"));
}

TEST_F(RedisClient, ACommandOutlastingTheTimeoutFailsAndTheNextOneReconnects) {
  redis_limits limits = quick_limits();
  limits.command_timeout = 100ms;
  redis_client client(redis_.endpoint(), limits);
  ASSERT_TRUE(client.connect().ok());
  // BLPOP on an empty list with no timeout never answers: whatever the pauses of this test, the 100 ms command
  // timeout is what ends it.
  const auto waited = client.command({"BLPOP", "empty-list", "0"});
  ASSERT_FALSE(waited.ok());
  EXPECT_EQ(waited.error().code(), errc::io_error);
  EXPECT_FALSE(client.connected());  // the connection may still carry the late reply: dropped
  const auto after = command_until_ok(client, {"PING"});
  ASSERT_TRUE(after.ok()) << after.error().message();
  EXPECT_TRUE(after->is_status("PONG"));  // not the late BLPOP reply
  EXPECT_EQ(client.stats().connects, 2u);
}

TEST(RedisClientUnreachable, ConnectFailsWithAClearMessage) {
  const unsigned short port = free_loopback_port();  // nobody listens there
  redis_limits limits = quick_limits();
  limits.reconnect_backoff_initial = 60s;
  redis_client client({"127.0.0.1", port, 0}, limits);
  const status refused = client.connect();
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.code(), errc::io_error);
  EXPECT_NE(refused.message().find("redis://127.0.0.1:" + std::to_string(port) + "/0 is unreachable"),
            std::string::npos)
      << refused.message();
  EXPECT_FALSE(client.command({"PING"}).ok());
  EXPECT_EQ(client.stats().failed_connects, 1u);  // the command was refused inside the backoff window
}

}  // namespace
}  // namespace tracemesh::server
