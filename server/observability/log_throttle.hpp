#pragma once
/// @file log_throttle.hpp
/// Rate limit for log lines a client can provoke at will (a refusal by a per-client limit): at most one line per
/// client per interval, and at most max_clients clients remembered. When every remembered client was logged
/// within the interval, a new one is not logged but counted; the next line logged says how many were
/// suppressed. So neither the log nor this table grows with the rate of refusals or the number of addresses a
/// client can use. Thread-safe.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>

namespace tracemesh::server {

class log_throttle {
 public:
  using clock = std::chrono::steady_clock;

  log_throttle(clock::duration interval, std::size_t max_clients);

  /// Whether a refusal of `client` at `now` is logged; when it is, `suppressed` is the number of refusals not
  /// logged since the last line was (of any client).
  bool admit(const std::string& client, clock::time_point now, std::uint64_t& suppressed);

 private:
  /// Forgets clients logged at least one interval before `now`.
  void forget_expired(clock::time_point now);

  const clock::duration interval_;
  const std::size_t max_clients_;
  std::mutex mutex_;
  std::unordered_map<std::string, clock::time_point> last_logged_;
  std::uint64_t suppressed_ = 0;
};

}  // namespace tracemesh::server
