#include "server/jobs/eta_estimator.hpp"

#include <algorithm>
#include <cmath>

namespace tracemesh::server {

void eta_estimator::start(clock::time_point started) {
  std::lock_guard lock(mutex_);
  started_ = started;
  total_seconds_.reset();
  last_update_ = {};
}

void eta_estimator::observe(double progress, clock::time_point now) {
  std::lock_guard lock(mutex_);
  if (!started_ || !std::isfinite(progress) || progress < min_progress) return;
  if (total_seconds_ && now - last_update_ < min_interval) return;
  const double elapsed = std::chrono::duration<double>(now - *started_).count();
  const double estimate = elapsed / std::min(progress, 1.0);
  total_seconds_ = total_seconds_ ? (1 - smoothing) * *total_seconds_ + smoothing * estimate : estimate;
  last_update_ = now;
}

std::optional<double> eta_estimator::remaining_seconds(clock::time_point now) const {
  std::lock_guard lock(mutex_);
  if (!started_ || !total_seconds_) return std::nullopt;
  const double elapsed = std::chrono::duration<double>(now - *started_).count();
  return std::max(0.0, *total_seconds_ - elapsed);
}

}  // namespace tracemesh::server
