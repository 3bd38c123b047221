#pragma once
/// @file redis_job_events.hpp
/// The job-events channel of `tracemeshd --store redis://…` (issue 13): how a replica learns, without polling Redis,
/// that a job another replica runs changed, so its event streams (GET /jobs/{id}/events) send the change.
///
/// Publishing: every write of redis_job_records that changes what an event stream shows (acceptance, start, a new
/// stage or progress, the final state, a cancellation) PUBLISHes "<state> <job id>" on
/// redis_job_records::events_channel() in the same script or transaction as the write, so a message never arrives
/// before the record it announces.
///
/// Subscribing: one redis_job_events per replica runs a thread with its own connection (SUBSCRIBE blocks it, so it
/// cannot share redis_client's), and keeps a bounded map job id → the sequence number of its latest message.
/// version(id) changes whenever a message for the job arrives, when the subscriber (re)subscribes (messages may
/// have been lost while it was away), and when the job's entry is forgotten (its final message, or the bound
/// replica_limits::max_event_jobs); it is std::nullopt while the subscriber is not subscribed, when a caller must
/// read the record itself. A caller reads the record when the version differs from the one it read at; a missed
/// message is covered by replica_limits::event_fallback (see api_handlers.cpp, job_event_source).
///
/// Reconnects with the backoff of redis_limits (reconnect_backoff_initial doubled up to reconnect_backoff_max).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>

#include "core/status.hpp"
#include "server/redis/redis_url.hpp"
#include "server/admission/server_limits.hpp"

namespace tracemesh::server {

/// Counters of one subscriber, for tests.
struct redis_job_events_stats {
  std::uint64_t subscribes = 0;  ///< successful SUBSCRIBEs (the first one included)
  std::uint64_t messages = 0;    ///< job messages received
  std::uint64_t failures = 0;    ///< connections that failed or broke
};

class redis_job_events {
 public:
  /// Does not connect: start() does. `channel` is redis_job_records::events_channel(); `max_jobs` bounds the map.
  /// `stop_poll` is how long the thread may take to see stop().
  redis_job_events(redis_endpoint endpoint, redis_limits limits, std::string channel, std::size_t max_jobs,
                   std::chrono::milliseconds stop_poll = std::chrono::milliseconds(200));
  ~redis_job_events();  ///< stop()
  redis_job_events(const redis_job_events&) = delete;
  redis_job_events& operator=(const redis_job_events&) = delete;

  /// Starts the subscriber thread (idempotent). It retries a Redis that is down; it never fails.
  void start();
  /// Stops and joins the thread (idempotent).
  void stop();

  /// A number that changes when job `id` may have changed in the records since it was last returned (see the file
  /// comment); std::nullopt while not subscribed (read the record every time).
  std::optional<std::uint64_t> version(const std::string& id) const;
  bool subscribed() const { return subscribed_.load(std::memory_order_acquire); }
  /// Jobs remembered now (at most max_jobs).
  std::size_t remembered() const;
  redis_job_events_stats stats() const;

  /// The message published for job `id` in state `state` (a proto job state name), as the Lua scripts build it.
  static std::string message(std::string_view state, std::string_view id);

 private:
  void run();
  /// One connection: subscribes, then records messages until it breaks or stop(). The failure that ended it.
  status subscribe_once();
  void on_message(std::string_view payload);
  void on_subscribed();

  const redis_endpoint endpoint_;
  const redis_limits limits_;
  const std::string channel_;
  const std::size_t max_jobs_;
  const std::chrono::milliseconds stop_poll_;

  std::atomic<bool> stopping_{false};
  std::atomic<bool> subscribed_{false};
  std::thread thread_;

  mutable std::mutex mutex_;
  std::uint64_t sequence_ = 0;      // of the latest event (a message, a subscription, a forgotten entry)
  std::uint64_t subscribed_at_ = 0;  // sequence of the latest subscription
  std::uint64_t forgotten_at_ = 0;   // sequence of the latest forgotten entry
  std::unordered_map<std::string, std::uint64_t> latest_;  // job id → sequence of its latest message
  std::map<std::uint64_t, std::string> by_age_;             // the same, oldest first
  redis_job_events_stats stats_;
};

}  // namespace tracemesh::server
