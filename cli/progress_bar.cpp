#include "cli/progress_bar.hpp"

#include <algorithm>
#include <cmath>

#include "core/stage_weights.hpp"

namespace tracemesh::cli {

void progress_bar::update(mesh_stage stage, double fraction) {
  if (!enabled_) return;
  if (stage == mesh_stage::done) {  // leave a clean line for whatever is printed next
    clear();
    return;
  }
  overall_ = std::max(overall_, overall_progress(method_, refine_, stage, fraction));
  const auto now = std::chrono::steady_clock::now();
  const bool stage_changed = !has_stage_ || stage != last_stage_;
  if (!stage_changed && now - last_draw_ < redraw_interval) return;
  has_stage_ = true;
  last_stage_ = stage;
  last_draw_ = now;
  draw(stage);
}

void progress_bar::draw(mesh_stage stage) {
  const int percent = static_cast<int>(std::floor(overall_ * 100));
  // \r returns to the line start, \033[K erases what a longer previous line left.
  std::fprintf(stream_, "\rtracemesh: %-13s %3d%%\033[K", stage_name(stage), percent);
  std::fflush(stream_);
  drawn_ = true;
}

void progress_bar::clear() {
  if (!drawn_) return;
  std::fputs("\r\033[K", stream_);
  std::fflush(stream_);
  drawn_ = false;
}

}  // namespace tracemesh::cli
