#pragma once
/// @file hiredis_handles.hpp
/// Private helpers shared by the hiredis users of server/redis (redis_client.cpp, redis_job_events.cpp): owning
/// handles for hiredis contexts and replies, and timeouts as hiredis takes them.

#include <sys/time.h>

#include <chrono>
#include <memory>

#include <hiredis/hiredis.h>

namespace tracemesh::server::detail {

inline timeval to_timeval(std::chrono::milliseconds duration) {
  timeval tv{};
  tv.tv_sec = static_cast<time_t>(duration.count() / 1000);
  tv.tv_usec = static_cast<suseconds_t>((duration.count() % 1000) * 1000);
  return tv;
}

struct reply_deleter {
  void operator()(redisReply* reply) const noexcept { freeReplyObject(reply); }
};
using owned_reply = std::unique_ptr<redisReply, reply_deleter>;

}  // namespace tracemesh::server::detail
