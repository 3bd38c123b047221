#include "core/analysis/analysis_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/analysis/analysis_parallel.hpp"

namespace tracemesh::detail {
namespace {

/// A triangle's corners and the lengths of the edges opposite each corner.
struct triangle_shape {
  vec3 corner[3];
  double opposite_edge[3];

  triangle_shape(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& t)
      : corner{mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]},
        opposite_edge{distance(corner[1], corner[2]), distance(corner[2], corner[0]), distance(corner[0], corner[1])} {}

  int corner_of_shortest_edge() const {
    if (opposite_edge[0] <= opposite_edge[1] && opposite_edge[0] <= opposite_edge[2]) return 0;
    return opposite_edge[1] <= opposite_edge[2] ? 1 : 2;
  }
  double shortest_edge() const { return std::min({opposite_edge[0], opposite_edge[1], opposite_edge[2]}); }
  double longest_edge() const { return std::max({opposite_edge[0], opposite_edge[1], opposite_edge[2]}); }
  double area() const { return 0.5 * norm(cross(corner[1] - corner[0], corner[2] - corner[0])); }

  /// The smallest interior angle (degrees): the one opposite the shortest edge. atan2 stays accurate for slivers.
  double min_angle_deg() const {
    const int k = corner_of_shortest_edge();
    const vec3 u = corner[(k + 1) % 3] - corner[k];
    const vec3 w = corner[(k + 2) % 3] - corner[k];
    return std::atan2(norm(cross(u, w)), dot(u, w)) * (180.0 / std::numbers::pi);
  }
};

struct quality_partial {
  std::size_t triangles = 0;
  double ratio_sum = 0;
  double ratio_min = std::numeric_limits<double>::infinity();
  std::array<std::size_t, 10> histogram{};
  std::size_t below_0_2 = 0;
  double min_angle_deg = std::numeric_limits<double>::infinity();
};

void add_triangle(quality_partial& partial, const triangle_shape& shape) {
  const double longest = shape.longest_edge();
  const double ratio = longest > 0 ? shape.shortest_edge() / longest : 0.0;
  ++partial.triangles;
  partial.ratio_sum += ratio;
  partial.ratio_min = std::min(partial.ratio_min, ratio);
  ++partial.histogram[std::min<std::size_t>(9, static_cast<std::size_t>(ratio * 10))];
  if (ratio < 0.2) ++partial.below_0_2;
  partial.min_angle_deg = std::min(partial.min_angle_deg, shape.min_angle_deg());
}

quality_partial merge(quality_partial total, const quality_partial& part) {
  total.triangles += part.triangles;
  total.ratio_sum += part.ratio_sum;
  total.ratio_min = std::min(total.ratio_min, part.ratio_min);
  for (std::size_t bin = 0; bin < total.histogram.size(); ++bin) total.histogram[bin] += part.histogram[bin];
  total.below_0_2 += part.below_0_2;
  total.min_angle_deg = std::min(total.min_angle_deg, part.min_angle_deg);
  return total;
}

}  // namespace

bool usable_coordinate(const vec3& p) {
  const auto ok = [](double v) { return std::isfinite(v) && std::abs(v) <= max_analysed_coordinate; };
  return ok(p.x) && ok(p.y) && ok(p.z);
}

triangle_defect classify_triangle(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& t) {
  const std::size_t n = mesh.positions.size();
  if (t[0] >= n || t[1] >= n || t[2] >= n) return triangle_defect::index_out_of_range;
  if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) return triangle_defect::repeated_index;
  for (const std::uint32_t index : t) {
    if (!usable_coordinate(mesh.positions[index])) return triangle_defect::bad_coordinate;
  }
  const triangle_shape shape(mesh, t);
  if (shape.shortest_edge() < degenerate_edge_length) return triangle_defect::short_edge;
  const double longest = shape.longest_edge();
  if (shape.area() < degenerate_area_ratio * longest * longest) return triangle_defect::zero_area;
  return triangle_defect::none;
}

std::vector<triangle_defect> classify_triangles(const surface_mesh& mesh) {
  std::vector<triangle_defect> defects(mesh.triangles.size());
  for_each_chunk(mesh.triangles.size(), [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t < end; ++t) defects[t] = classify_triangle(mesh, mesh.triangles[t]);
  });
  return defects;
}

quality_report measure_triangle_quality(const surface_mesh& mesh, const std::vector<triangle_defect>& defects) {
  const quality_partial total = deterministic_reduce(
      mesh.triangles.size(), quality_partial{},
      [&](std::size_t begin, std::size_t end) {
        quality_partial partial;
        for (std::size_t t = begin; t < end; ++t) {
          if (has_usable_geometry(defects[t])) add_triangle(partial, triangle_shape(mesh, mesh.triangles[t]));
        }
        return partial;
      },
      merge);
  quality_report quality;
  if (total.triangles == 0) return quality;
  const auto count = static_cast<double>(total.triangles);
  quality.edge_ratio_mean = total.ratio_sum / count;
  quality.edge_ratio_min = total.ratio_min;
  quality.edge_ratio_histogram = total.histogram;
  quality.fraction_below_0_2 = static_cast<double>(total.below_0_2) / count;
  quality.min_angle_deg = total.min_angle_deg;
  return quality;
}

void measure_edge_lengths(std::vector<double>& lengths, quality_report& quality) {
  if (lengths.empty()) return;
  const auto [shortest, longest] = std::minmax_element(lengths.begin(), lengths.end());
  quality.shortest_edge = *shortest;
  quality.longest_edge = *longest;
  const std::size_t middle = lengths.size() / 2;
  std::nth_element(lengths.begin(), lengths.begin() + static_cast<std::ptrdiff_t>(middle), lengths.end());
  const double upper_middle = lengths[middle];
  if (lengths.size() % 2 == 1) {
    quality.median_edge = upper_middle;
  } else {
    // After nth_element everything before `middle` is ≤ it: the lower middle is their maximum.
    const double lower_middle =
        *std::max_element(lengths.begin(), lengths.begin() + static_cast<std::ptrdiff_t>(middle));
    quality.median_edge = 0.5 * (lower_middle + upper_middle);
  }
}

}  // namespace tracemesh::detail
