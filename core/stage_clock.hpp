#pragma once
/// @file stage_clock.hpp
/// Seconds per pipeline stage, as the report gives them.

#include <chrono>
#include <vector>

#include "core/progress.hpp"

namespace tracemesh {

struct stage_timing {
  mesh_stage stage;
  double seconds;
};

/// Appends one timing per finished stage: the time since the previous finish (or since construction).
class stage_clock {
 public:
  explicit stage_clock(std::vector<stage_timing>& timings) : timings_(timings) {}
  void finish(mesh_stage stage) {
    const auto now = std::chrono::steady_clock::now();
    timings_.push_back({stage, std::chrono::duration<double>(now - start_).count()});
    start_ = now;
  }

 private:
  std::vector<stage_timing>& timings_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace tracemesh
