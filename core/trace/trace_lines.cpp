#include "core/trace/trace_lines.hpp"

#include <algorithm>
#include <cmath>

namespace tracemesh {

trace_lines::trace_lines(std::vector<entry> entries) {
  std::sort(entries.begin(), entries.end(), [](const entry& a, const entry& b) {
    if (!(a.line == b.line)) return a.line < b.line;
    return a.point.x < b.point.x;
  });
  first_.push_back(0);
  for (const entry& e : entries) {
    const bool new_line = ids_.empty() || !(ids_.back() == e.line);
    if (!new_line && e.point.x - points_.back().x < merge_tolerance) continue;  // the same root twice
    if (new_line) {
      ids_.push_back(e.line);
      first_.push_back(points_.size());
    }
    points_.push_back(e.point);
    first_.back() = points_.size();
  }
}

std::size_t trace_lines::find(const line_id& line) const {
  const auto it = std::lower_bound(ids_.begin(), ids_.end(), line);
  return it != ids_.end() && *it == line ? static_cast<std::size_t>(it - ids_.begin()) : ids_.size();
}

std::span<const line_point> trace_lines::roots_of(const line_id& line) const {
  const std::size_t n = find(line);
  return n == ids_.size() ? std::span<const line_point>{} : roots(n);
}

std::int64_t trace_lines::match(std::span<const line_point> roots, double x) const {
  const auto it = std::lower_bound(roots.begin(), roots.end(), x,
                                   [](const line_point& p, double value) { return p.x < value; });
  const std::int64_t after = it - roots.begin();  // the candidates are the roots at after − 1 and after
  std::int64_t best = -1;
  double best_distance = merge_tolerance;
  for (const std::int64_t candidate : {after - 1, after}) {
    if (candidate < 0 || candidate >= static_cast<std::int64_t>(roots.size())) continue;
    const double d = std::abs(roots[static_cast<std::size_t>(candidate)].x - x);
    if (d < best_distance) {
      best_distance = d;
      best = candidate;
    }
  }
  return best;
}

std::vector<trace_lines::entry> trace_lines::entries() const {
  std::vector<entry> out;
  out.reserve(points_.size());
  for (std::size_t n = 0; n < ids_.size(); ++n) {
    for (const line_point& p : roots(n)) out.push_back({ids_[n], p});
  }
  return out;
}

}  // namespace tracemesh
