#pragma once
/// @file eta_estimator.hpp
/// A running job's expected remaining seconds (the job JSON's `eta_s`), from its elapsed time and its overall
/// progress (proportional to expected time, core/stage_weights.hpp): the run's total time is estimated as
/// elapsed / progress, smoothed exponentially so that one fast or slow stretch does not make the ETA jump, and the
/// ETA is that total minus the time elapsed when asked (so it counts down smoothly between progress reports).
/// Thread-safe: progress is observed on a worker thread, the ETA read by request handlers.

#include <chrono>
#include <mutex>
#include <optional>

namespace tracemesh::server {

class eta_estimator {
 public:
  using clock = std::chrono::steady_clock;

  /// Below this progress the estimate is too noisy (start-up costs dominate): the ETA is unknown.
  static constexpr double min_progress = 0.02;
  /// Estimates are folded in at most this often, so that a burst of reports weighs as much as one.
  static constexpr std::chrono::milliseconds min_interval{200};
  /// Weight of a new estimate in the running total (exponential smoothing).
  static constexpr double smoothing = 0.3;

  /// The run started at `started`; forgets earlier estimates.
  void start(clock::time_point started);
  /// Overall progress `progress` (0..1) was reached at `now`.
  void observe(double progress, clock::time_point now);
  /// Seconds left at `now` (≥ 0), or nullopt while unknown (not started, or progress below min_progress).
  std::optional<double> remaining_seconds(clock::time_point now) const;

 private:
  mutable std::mutex mutex_;
  std::optional<clock::time_point> started_;
  std::optional<double> total_seconds_;  // smoothed estimate of the run's whole duration
  clock::time_point last_update_{};
};

}  // namespace tracemesh::server
