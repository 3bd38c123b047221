#include "server/observability/log_throttle.hpp"

namespace tracemesh::server {

log_throttle::log_throttle(clock::duration interval, std::size_t max_clients)
    : interval_(interval), max_clients_(max_clients) {}

bool log_throttle::admit(const std::string& client, clock::time_point now, std::uint64_t& suppressed) {
  std::lock_guard lock(mutex_);
  const auto found = last_logged_.find(client);
  if (found != last_logged_.end() && now - found->second < interval_) {
    ++suppressed_;
    return false;
  }
  if (found == last_logged_.end() && last_logged_.size() >= max_clients_) forget_expired(now);
  if (found == last_logged_.end() && last_logged_.size() >= max_clients_) {
    ++suppressed_;
    return false;
  }
  last_logged_[client] = now;
  suppressed = suppressed_;
  suppressed_ = 0;
  return true;
}

void log_throttle::forget_expired(clock::time_point now) {
  for (auto entry = last_logged_.begin(); entry != last_logged_.end();) {
    entry = now - entry->second >= interval_ ? last_logged_.erase(entry) : std::next(entry);
  }
}

}  // namespace tracemesh::server
