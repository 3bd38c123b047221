#pragma once
/// @file progress_bar.hpp
/// A one-line progress display on a terminal: "tracemesh: <stage> <percent>%", redrawn in place at most
/// ~10 times a second. The percentage is of the whole run, proportional to expected time (the stage weights of the
/// run's path, core/stage_weights.hpp, as the service's job progress), and never goes backwards. Fed by a
/// progress_token listener; writes nothing when disabled (stderr not a TTY).

#include <chrono>
#include <cstdio>
#include <string>

#include "core/mesher.hpp"
#include "core/progress.hpp"

namespace tracemesh::cli {

class progress_bar {
 public:
  /// Draws on `stream` only when `enabled` (the caller passes isatty(stderr)); the run meshes with (method, refine).
  progress_bar(std::FILE* stream, bool enabled, mesh_method method, refine_mode refine)
      : stream_(stream), enabled_(enabled), method_(method), refine_(refine) {}
  ~progress_bar() { clear(); }
  progress_bar(const progress_bar&) = delete;
  progress_bar& operator=(const progress_bar&) = delete;

  /// Records progress; redraws when the stage changed or 100 ms passed since the last redraw. Erases the line
  /// at mesh_stage::done.
  /// Not thread-safe by itself: progress_token serialises its listener calls.
  void update(mesh_stage stage, double fraction);

  /// Erases the line (before printing anything else, and at the end).
  void clear();

 private:
  static constexpr std::chrono::milliseconds redraw_interval{100};

  void draw(mesh_stage stage);

  std::FILE* stream_;
  bool enabled_;
  mesh_method method_;
  refine_mode refine_;
  double overall_ = 0;  // of the whole run, 0..1, never decreasing
  bool drawn_ = false;
  bool has_stage_ = false;
  mesh_stage last_stage_ = mesh_stage::reading;
  std::chrono::steady_clock::time_point last_draw_{};
};

}  // namespace tracemesh::cli
