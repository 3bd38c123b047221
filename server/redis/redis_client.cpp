#include "server/redis/redis_client.hpp"

#include <sys/time.h>

#include <algorithm>

#include <hiredis/hiredis.h>

#include "server/redis/detail/hiredis_handles.hpp"

namespace tracemesh::server {

namespace {

using detail::owned_reply;
using detail::to_timeval;

redis_reply convert(const redisReply& raw) {
  redis_reply reply;
  switch (raw.type) {
    case REDIS_REPLY_INTEGER:
      reply.type = redis_reply::kind::integer;
      reply.integer = raw.integer;
      break;
    case REDIS_REPLY_STRING:
    case REDIS_REPLY_STATUS:
    case REDIS_REPLY_ERROR:
      reply.type = raw.type == REDIS_REPLY_STRING   ? redis_reply::kind::string
                   : raw.type == REDIS_REPLY_STATUS ? redis_reply::kind::status
                                                    : redis_reply::kind::error;
      reply.text.assign(raw.str, raw.len);
      break;
    case REDIS_REPLY_ARRAY:
      reply.type = redis_reply::kind::array;
      reply.elements.reserve(raw.elements);
      for (std::size_t i = 0; i < raw.elements; ++i) reply.elements.push_back(convert(*raw.element[i]));
      break;
    default:  // REDIS_REPLY_NIL (RESP2 has no other type)
      break;
  }
  return reply;
}

/// Queues one command on the context's output buffer; false when hiredis could not (out of memory).
bool append(redisContext* context, const std::vector<std::string>& arguments) {
  std::vector<const char*> argv;
  std::vector<std::size_t> lengths;
  argv.reserve(arguments.size());
  lengths.reserve(arguments.size());
  for (const std::string& argument : arguments) {
    argv.push_back(argument.data());
    lengths.push_back(argument.size());
  }
  return redisAppendCommandArgv(context, static_cast<int>(argv.size()), argv.data(), lengths.data()) == REDIS_OK;
}

std::string context_error(const redisContext* context) {
  if (context == nullptr) return "out of memory";
  return context->errstr[0] != '\0' ? std::string(context->errstr) : "connection error";
}

/// "Redis at redis://h:p/db is unreachable<detail>" (built with append: see redis_url.cpp on GCC 12's -Wrestrict).
status unreachable(const redis_endpoint& endpoint, std::string_view detail) {
  std::string message = "Redis at ";
  message.append(endpoint.to_url()).append(" is unreachable").append(detail);
  return status(errc::io_error, std::move(message));
}

}  // namespace

status redis_refused(std::string_view what, const redis_reply& reply) {
  std::string message = "Redis refused ";
  message.append(what).append(": ").append(reply.text);
  return status(errc::io_error, std::move(message));
}

void redis_client::context_deleter::operator()(redisContext* context) const noexcept { redisFree(context); }

redis_client::redis_client(redis_endpoint endpoint, redis_limits limits)
    : endpoint_(std::move(endpoint)), limits_(limits) {}

redis_client::~redis_client() = default;

bool redis_client::connected() const {
  std::lock_guard lock(mutex_);
  return context_ != nullptr;
}

redis_client_stats redis_client::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

status redis_client::fail_locked(const std::string& what) {
  context_.reset();
  backoff_ = backoff_.count() == 0 ? limits_.reconnect_backoff_initial
                                   : std::min(backoff_ * 2, limits_.reconnect_backoff_max);
  retry_not_before_ = clock::now() + backoff_;
  return unreachable(endpoint_, ": " + what);
}

status redis_client::open_locked() {
  std::unique_ptr<redisContext, context_deleter> context(
      redisConnectWithTimeout(endpoint_.host.c_str(), endpoint_.port, to_timeval(limits_.connect_timeout)));
  if (context == nullptr || context->err != 0) {
    ++stats_.failed_connects;
    return fail_locked(context_error(context.get()));
  }
  redisEnableKeepAlive(context.get());
  if (redisSetTimeout(context.get(), to_timeval(limits_.command_timeout)) != REDIS_OK) {
    ++stats_.failed_connects;
    return fail_locked(context_error(context.get()));
  }
  // PING always, so connect() proves the server answers; SELECT when a database other than 0 is asked for.
  std::vector<std::vector<std::string>> handshake{{"PING"}};
  if (endpoint_.db != 0) handshake.push_back({"SELECT", std::to_string(endpoint_.db)});
  for (const auto& arguments : handshake) {
    if (!append(context.get(), arguments)) {
      ++stats_.failed_connects;
      return fail_locked("out of memory");
    }
  }
  for (const auto& arguments : handshake) {
    void* raw = nullptr;
    if (redisGetReply(context.get(), &raw) != REDIS_OK || raw == nullptr) {
      ++stats_.failed_connects;
      return fail_locked(context_error(context.get()));
    }
    const owned_reply reply(static_cast<redisReply*>(raw));
    if (reply->type == REDIS_REPLY_ERROR) {
      ++stats_.failed_connects;
      std::string what = arguments.front();
      what.append(" answered ").append(reply->str, reply->len);
      return fail_locked(what);
    }
  }
  context_ = std::move(context);
  backoff_ = std::chrono::milliseconds(0);
  ++stats_.connects;
  return status::success();
}

status redis_client::ensure_connected_locked(bool ignore_backoff) {
  if (context_ != nullptr) return status::success();
  if (!ignore_backoff && clock::now() < retry_not_before_) {
    ++stats_.backoff_rejections;
    return unreachable(endpoint_, " (retrying after backoff)");
  }
  return open_locked();
}

status redis_client::connect() {
  std::lock_guard lock(mutex_);
  return ensure_connected_locked(/*ignore_backoff=*/true);
}

result<redis_reply> redis_client::command(const std::vector<std::string>& arguments) {
  auto replies = pipeline({arguments});
  if (!replies.ok()) return replies.error();
  return std::move(replies.value().front());
}

result<std::vector<redis_reply>> redis_client::pipeline(const std::vector<std::vector<std::string>>& commands) {
  for (const auto& arguments : commands) {
    if (arguments.empty()) return status(errc::invalid_argument, "empty Redis command");
  }
  std::lock_guard lock(mutex_);
  if (status connected = ensure_connected_locked(/*ignore_backoff=*/false); !connected.ok()) return connected;
  for (const auto& arguments : commands) {
    if (!append(context_.get(), arguments)) {
      ++stats_.failed_commands;
      return fail_locked("out of memory");
    }
  }
  std::vector<redis_reply> replies;
  replies.reserve(commands.size());
  for (std::size_t i = 0; i < commands.size(); ++i) {
    void* raw = nullptr;
    if (redisGetReply(context_.get(), &raw) != REDIS_OK || raw == nullptr) {
      ++stats_.failed_commands;
      return fail_locked(context_error(context_.get()));
    }
    replies.push_back(convert(*owned_reply(static_cast<redisReply*>(raw))));
  }
  return replies;
}

}  // namespace tracemesh::server
