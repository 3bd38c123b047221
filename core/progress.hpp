#pragma once
/// @file progress.hpp
/// A progress/cancel token passed through long work (modelled on OpenVDB's interrupter).
/// The pipeline calls report() at coarse granularity and stops with errc::cancelled once cancelled() is true.
/// Thread-safe: workers may report and poll concurrently.

#include <atomic>
#include <functional>
#include <mutex>
#include <string_view>

namespace tracemesh {

/// Pipeline stages, in order, as reported to progress listeners.
/// The lattice path runs sampling → roots → triangulating; the trace path roots (line roots, eq. 6) → tracing
/// (Algorithm 1) → triangulating (Algorithm 2 and the polygons' triangulation).
enum class mesh_stage { reading, culling, sampling, roots, tracing, triangulating, refining, certifying, encoding, done };
const char* stage_name(mesh_stage stage) noexcept;

class progress_token {
 public:
  /// Called with the stage and the fraction of that stage done (0..1); may be called from any thread.
  using listener = std::function<void(mesh_stage, double)>;

  progress_token() = default;
  explicit progress_token(listener on_progress) : on_progress_(std::move(on_progress)) {}

  /// Ask the work to stop; idempotent, callable from any thread.
  void cancel() noexcept { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const noexcept { return cancelled_.load(std::memory_order_relaxed); }

  /// Report progress; returns false when the work should stop. Within one stage, a fraction below one already
  /// passed on is dropped: parallel workers number their finished items in one order and report them in another,
  /// and a listener must never see progress go backwards.
  bool report(mesh_stage stage, double fraction) {
    if (on_progress_) {
      std::lock_guard lock(mutex_);
      if (stage != last_stage_ || fraction >= last_fraction_) {
        last_stage_ = stage;
        last_fraction_ = fraction;
        on_progress_(stage, fraction);
      }
    }
    return !cancelled();
  }

 private:
  listener on_progress_;
  std::mutex mutex_;
  mesh_stage last_stage_ = mesh_stage::reading;  ///< guarded by mutex_, as last_fraction_
  double last_fraction_ = -1;
  std::atomic<bool> cancelled_{false};
};

}  // namespace tracemesh
