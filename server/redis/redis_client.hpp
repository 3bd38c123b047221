#pragma once
/// @file redis_client.hpp
/// A synchronous Redis connection (hiredis) for the replicated store of `tracemeshd --store redis://…`.
///
/// Blocking by design: it is called from worker and prep threads, never from an HTTP I/O thread, and every wait is
/// bounded by redis_limits (connect and command timeouts). Failures are values: a connection that cannot be made or
/// breaks mid-command is an errc::io_error status naming the endpoint; an error *reply* of Redis (WRONGTYPE,
/// BUSYGROUP...) is a successful round trip and comes back as a redis_reply of kind error, for the caller to judge.
///
/// Reconnect with backoff: after a failure the connection is dropped; the next command after the backoff window
/// connects again (and SELECTs the database). Inside the window commands fail at once without touching the
/// network; the window doubles with each further failure up to redis_limits::reconnect_backoff_max and resets on
/// success. A failed command is never re-sent (XADD, INCR... are not idempotent): the caller decides.
///
/// Thread safety: one client may be shared; its commands are serialised by an internal mutex.

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.hpp"
#include "server/redis/redis_url.hpp"
#include "server/admission/server_limits.hpp"

struct redisContext;  // hiredis; kept out of this header

namespace tracemesh::server {

/// One Redis reply (RESP2): nil, integer, bulk string, status line, error line, or an array of replies.
struct redis_reply {
  enum class kind { nil, integer, string, status, error, array };
  kind type = kind::nil;
  long long integer = 0;            ///< kind::integer
  std::string text;                 ///< kind::string, kind::status ("OK", "PONG") and kind::error ("ERR ...")
  std::vector<redis_reply> elements;  ///< kind::array

  bool is_nil() const noexcept { return type == kind::nil; }
  bool is_error() const noexcept { return type == kind::error; }
  /// True for a status reply with exactly this text ("OK", "PONG", "QUEUED").
  bool is_status(std::string_view expected) const { return type == kind::status && text == expected; }
};

/// Counters of one client, for metrics and tests.
struct redis_client_stats {
  std::uint64_t connects = 0;           ///< successful connections (the first one included)
  std::uint64_t failed_connects = 0;    ///< connect or SELECT attempts that failed
  std::uint64_t failed_commands = 0;    ///< commands lost to a broken connection or a timeout
  std::uint64_t backoff_rejections = 0; ///< commands refused inside the backoff window
};

class redis_client {
 public:
  /// Does not connect: the first command does (see connect() to check reachability up front).
  redis_client(redis_endpoint endpoint, redis_limits limits);
  ~redis_client();
  redis_client(const redis_client&) = delete;
  redis_client& operator=(const redis_client&) = delete;

  /// Connects now (if not connected) and checks the server answers PING; ignores the backoff window, so a start-up
  /// check always really tries. @return errc::io_error "Redis at redis://h:p/db is unreachable: <reason>".
  status connect();

  /// Sends one command (each argument one bulk string, binary-safe) and waits for its reply.
  /// @return the reply (kind::error for a Redis error reply); errc::io_error when the connection cannot be made,
  ///         breaks or times out, or when inside the backoff window after such a failure.
  result<redis_reply> command(const std::vector<std::string>& arguments);

  /// Pipelines several commands in one round trip: replies in order, one per command.
  /// @return errc::io_error as command(); then no reply of the batch is known (some may have run).
  result<std::vector<redis_reply>> pipeline(const std::vector<std::vector<std::string>>& commands);

  const redis_endpoint& endpoint() const noexcept { return endpoint_; }
  const redis_limits& limits() const noexcept { return limits_; }
  bool connected() const;
  redis_client_stats stats() const;

 private:
  struct context_deleter {
    void operator()(redisContext* context) const noexcept;
  };
  using clock = std::chrono::steady_clock;

  status ensure_connected_locked(bool ignore_backoff);
  status open_locked();
  status fail_locked(const std::string& what);  ///< drops the connection, widens the backoff window

  const redis_endpoint endpoint_;
  const redis_limits limits_;
  mutable std::mutex mutex_;
  std::unique_ptr<redisContext, context_deleter> context_;
  clock::time_point retry_not_before_{};
  std::chrono::milliseconds backoff_{0};
  redis_client_stats stats_;
};

/// errc::io_error "Redis refused <what>: <the error reply's text>", for a Redis error reply a caller cannot accept.
status redis_refused(std::string_view what, const redis_reply& reply);

}  // namespace tracemesh::server
