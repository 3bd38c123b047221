#include "server/redis/redis_job_events.hpp"

#include <poll.h>
#include <algorithm>
#include <cerrno>
#include <memory>
#include <vector>

#include <hiredis/hiredis.h>

#include "proto/api_types.hpp"
#include "server/redis/detail/hiredis_handles.hpp"

namespace tracemesh::server {

namespace {

using detail::owned_reply;
using detail::to_timeval;

struct context_deleter {
  void operator()(redisContext* context) const noexcept { redisFree(context); }
};
using owned_context = std::unique_ptr<redisContext, context_deleter>;

status broken(const redis_endpoint& endpoint, const redisContext* context, std::string_view what) {
  std::string message = "job-events subscription to ";
  message.append(endpoint.to_url()).append(": ").append(what);
  if (context != nullptr && context->errstr[0] != '\0') message.append(": ").append(context->errstr);
  return status(errc::io_error, std::move(message));
}

/// The element `i` of a pub/sub array reply as text ("" when absent or not a string).
std::string_view element_text(const redisReply& reply, std::size_t i) {
  if (reply.type != REDIS_REPLY_ARRAY || i >= reply.elements) return {};
  const redisReply* element = reply.element[i];
  if (element->type != REDIS_REPLY_STRING && element->type != REDIS_REPLY_STATUS) return {};
  return {element->str, element->len};
}

}  // namespace

std::string redis_job_events::message(std::string_view state, std::string_view id) {
  std::string text(state);
  text.append(" ").append(id);
  return text;
}

redis_job_events::redis_job_events(redis_endpoint endpoint, redis_limits limits, std::string channel,
                                   std::size_t max_jobs, std::chrono::milliseconds stop_poll)
    : endpoint_(std::move(endpoint)),
      limits_(limits),
      channel_(std::move(channel)),
      max_jobs_(std::max<std::size_t>(1, max_jobs)),
      stop_poll_(std::max(stop_poll, std::chrono::milliseconds(1))) {}

redis_job_events::~redis_job_events() { stop(); }

void redis_job_events::start() {
  if (thread_.joinable()) return;
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
}

void redis_job_events::stop() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
  subscribed_ = false;
}

std::optional<std::uint64_t> redis_job_events::version(const std::string& id) const {
  if (!subscribed()) return std::nullopt;
  std::lock_guard lock(mutex_);
  const auto found = latest_.find(id);
  const std::uint64_t own = found != latest_.end() ? found->second : forgotten_at_;
  return std::max(own, subscribed_at_);
}

std::size_t redis_job_events::remembered() const {
  std::lock_guard lock(mutex_);
  return latest_.size();
}

redis_job_events_stats redis_job_events::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void redis_job_events::on_subscribed() {
  std::lock_guard lock(mutex_);
  subscribed_at_ = ++sequence_;
  ++stats_.subscribes;
  subscribed_.store(true, std::memory_order_release);
}

void redis_job_events::on_message(std::string_view payload) {
  const std::size_t space = payload.find(' ');
  if (space == std::string_view::npos || space + 1 >= payload.size()) return;  // not a message this version sends
  const result<proto::job_state> state = proto::parse_job_state(payload.substr(0, space));
  std::string id(payload.substr(space + 1));
  std::lock_guard lock(mutex_);
  ++stats_.messages;
  const std::uint64_t now = ++sequence_;
  if (const auto found = latest_.find(id); found != latest_.end()) {
    by_age_.erase(found->second);
    latest_.erase(found);
  }
  if (state.ok() && proto::is_final(*state)) {  // its last message: forget it (its version still moves on)
    forgotten_at_ = now;
    return;
  }
  if (latest_.size() >= max_jobs_) {  // the oldest is forgotten; its streams read their record once more
    const auto oldest = by_age_.begin();
    latest_.erase(oldest->second);
    by_age_.erase(oldest);
    forgotten_at_ = now;
  }
  latest_.emplace(id, now);
  by_age_.emplace(now, std::move(id));
}

void redis_job_events::run() {
  std::chrono::milliseconds backoff{0};
  while (!stopping_) {
    const std::uint64_t subscribes_before = stats().subscribes;
    (void)subscribe_once();  // the failure is the subscriber's own business: /readyz follows the command client
    subscribed_.store(false, std::memory_order_release);
    if (stopping_) break;
    {
      std::lock_guard lock(mutex_);
      ++stats_.failures;
    }
    // A subscription that worked starts the backoff over; a connection that never got that far widens it.
    backoff = stats().subscribes > subscribes_before || backoff.count() == 0
                  ? limits_.reconnect_backoff_initial
                  : std::min(backoff * 2, limits_.reconnect_backoff_max);
    const auto resume = std::chrono::steady_clock::now() + backoff;
    while (!stopping_ && std::chrono::steady_clock::now() < resume) {
      std::this_thread::sleep_for(std::min(stop_poll_, backoff));
    }
  }
}

status redis_job_events::subscribe_once() {
  owned_context context(
      redisConnectWithTimeout(endpoint_.host.c_str(), endpoint_.port, to_timeval(limits_.connect_timeout)));
  if (context == nullptr || context->err != 0) return broken(endpoint_, context.get(), "connect");
  redisEnableKeepAlive(context.get());
  if (redisSetTimeout(context.get(), to_timeval(limits_.command_timeout)) != REDIS_OK) {
    return broken(endpoint_, context.get(), "timeout");
  }
  // Pub/sub channels ignore the database number: the channel name carries the key prefix instead.
  void* raw = redisCommand(context.get(), "SUBSCRIBE %b", channel_.data(), channel_.size());
  if (raw == nullptr) return broken(endpoint_, context.get(), "SUBSCRIBE");
  {
    const owned_reply reply(static_cast<redisReply*>(raw));
    if (element_text(*reply, 0) != "subscribe") return broken(endpoint_, nullptr, "SUBSCRIBE refused");
  }
  on_subscribed();
  const int wait_ms = static_cast<int>(stop_poll_.count());
  while (!stopping_) {
    raw = nullptr;
    // Replies already read into hiredis's buffer first; then wait (at most stop_poll_) for the socket.
    if (redisReaderGetReply(context->reader, &raw) != REDIS_OK) return broken(endpoint_, context.get(), "protocol");
    if (raw == nullptr) {
      pollfd ready{context->fd, POLLIN, 0};
      const int polled = ::poll(&ready, 1, wait_ms);
      if (polled < 0 && errno != EINTR) return broken(endpoint_, nullptr, "poll");
      if (polled <= 0) continue;
      if (redisBufferRead(context.get()) != REDIS_OK) return broken(endpoint_, context.get(), "read");
      continue;
    }
    const owned_reply reply(static_cast<redisReply*>(raw));
    if (element_text(*reply, 0) == "message") on_message(element_text(*reply, 2));
  }
  return status::success();
}

}  // namespace tracemesh::server
