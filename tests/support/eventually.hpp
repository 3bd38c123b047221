#pragma once
// The one way a test waits for something another thread or process makes happen.
#include <chrono>
#include <functional>
#include <thread>

namespace tracemesh::testing {

/// Polls `condition` every millisecond until it holds or `within` has passed; its last value. The 1 ms pause is the
/// polling interval of a wait on an event (the condition), not a wait for time to pass. The deadline only
/// bounds how long a failing test takes: it is generous so that a loaded or slow machine never turns a wait into a
/// failure (a passing test returns as soon as the condition holds).
inline bool eventually(const std::function<bool()>& condition, std::chrono::milliseconds within = std::chrono::seconds(120)) {
  const auto deadline = std::chrono::steady_clock::now() + within;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= deadline) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace tracemesh::testing
