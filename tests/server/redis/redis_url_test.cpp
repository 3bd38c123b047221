#include "server/redis/redis_url.hpp"

#include <gtest/gtest.h>

namespace tracemesh::server {
namespace {

TEST(RedisUrl, ParsesHostPortAndDatabase) {
  const auto endpoint = parse_redis_url("redis://redis.lab-1.example:6380/3");
  ASSERT_TRUE(endpoint.ok()) << endpoint.error().message();
  EXPECT_EQ(endpoint->host, "redis.lab-1.example");
  EXPECT_EQ(endpoint->port, 6380);
  EXPECT_EQ(endpoint->db, 3u);
  EXPECT_EQ(endpoint->to_url(), "redis://redis.lab-1.example:6380/3");
}

TEST(RedisUrl, PortAndDatabaseDefaultTo6379AndZero) {
  for (const char* url : {"redis://127.0.0.1", "redis://127.0.0.1/", "redis://127.0.0.1:6379/0"}) {
    const auto endpoint = parse_redis_url(url);
    ASSERT_TRUE(endpoint.ok()) << url << ": " << endpoint.error().message();
    EXPECT_EQ(endpoint->to_url(), "redis://127.0.0.1:6379/0") << url;
  }
}

TEST(RedisUrl, AcceptsBracketedIpv6) {
  const auto endpoint = parse_redis_url("redis://[::1]:7000/1");
  ASSERT_TRUE(endpoint.ok()) << endpoint.error().message();
  EXPECT_EQ(endpoint->host, "::1");
  EXPECT_EQ(endpoint->port, 7000);
  EXPECT_EQ(endpoint->to_url(), "redis://[::1]:7000/1");
  EXPECT_TRUE(parse_redis_url(endpoint->to_url()).ok());
}

TEST(RedisUrl, RefusesMalformedUrlsNamingTheProblem) {
  const std::pair<const char*, const char*> cases[] = {
      {"", "must start with redis://"},
      {"http://h:1", "must start with redis://"},
      {"rediss://h:1", "TLS"},
      {"redis://", "no host"},
      {"redis://:6379", "no host"},
      {"redis://user:secret@h:1", "password"},
      {"redis://h:1?db=2", "query"},
      {"redis://h:0", "port '0'"},
      {"redis://h:65536", "port '65536'"},
      {"redis://h:", "port ''"},
      {"redis://h:12x", "port '12x'"},
      {"redis://h:-1", "port '-1'"},
      {"redis://h:1/x", "database 'x'"},
      {"redis://h:1/-1", "database '-1'"},
      {"redis://h:1/2/3", "database '2/3'"},
      {"redis://h:1/99999999999", "database"},
      {"redis://bad_host:1", "host 'bad_host' is not a host"},
      {"redis://-h:1", "is not a host"},
      {"redis://[::1:1", "without ']'"},
      {"redis://[::1]x", "after ']'"},
      {"redis://[zz]:1", "host 'zz' is not an IPv6"},
  };
  for (const auto& [url, expected] : cases) {
    const auto endpoint = parse_redis_url(url);
    ASSERT_FALSE(endpoint.ok()) << url;
    EXPECT_EQ(endpoint.error().code(), errc::invalid_argument) << url;
    EXPECT_NE(endpoint.error().message().find(expected), std::string::npos)
        << url << " → " << endpoint.error().message();
    EXPECT_NE(endpoint.error().message().find("redis://HOST:PORT[/DB]"), std::string::npos) << url;
  }
}

}  // namespace
}  // namespace tracemesh::server
