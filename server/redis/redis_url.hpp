#pragma once
/// @file redis_url.hpp
/// Where a Redis server is: `tracemeshd --store redis://HOST:PORT[/DB]` parsed into an endpoint.

#include <cstdint>
#include <string>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh::server {

/// Largest database index accepted in a URL. Redis itself has 16 databases unless its `databases` setting says
/// more; an index it does not have fails at connect (SELECT), with Redis's own message.
inline constexpr unsigned max_redis_db_index = 1u << 20;

/// One Redis server and the database selected on it.
struct redis_endpoint {
  std::string host;        ///< host name, IPv4 address, or IPv6 address without its brackets
  std::uint16_t port = 6379;
  unsigned db = 0;         ///< SELECTed after each connect

  /// "redis://host:port/db" ("[::1]" for an IPv6 host): the same endpoint, for logs and error messages.
  std::string to_url() const;
};

/// Parses `redis://HOST[:PORT][/[DB]]` (PORT defaults to 6379, DB to 0).
/// HOST is a name or IPv4 address ([A-Za-z0-9.-], not starting or ending with '.' or '-') or an IPv6 address in
/// brackets; PORT is 1..65535; DB is a decimal index up to max_redis_db_index.
/// @return errc::invalid_argument naming what is wrong (another scheme, user:password, a query, a bad port...).
result<redis_endpoint> parse_redis_url(std::string_view url);

}  // namespace tracemesh::server
