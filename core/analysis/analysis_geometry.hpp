#pragma once
/// @file analysis_geometry.hpp
/// Per-triangle geometry for mesh_analysis: which triangles are ill-formed or degenerate, and the triangle and
/// edge quality statistics. Tolerances are the named constants of mesh_analysis.hpp.

#include <array>
#include <cstdint>
#include <vector>

#include "core/mesh.hpp"
#include "core/analysis/mesh_analysis.hpp"

namespace tracemesh::detail {

/// The first defect found in a triangle, checked in this order.
enum class triangle_defect : std::uint8_t {
  none,
  index_out_of_range,  ///< ill-formed: an index ≥ the vertex count
  repeated_index,      ///< ill-formed: two equal indices
  bad_coordinate,      ///< a corner is not finite or beyond max_analysed_coordinate
  short_edge,          ///< an edge shorter than degenerate_edge_length
  zero_area,           ///< area < degenerate_area_ratio · longest edge²
};

/// Three distinct in-range indices: the triangle takes part in topology.
inline bool is_well_formed(triangle_defect defect) {
  return defect != triangle_defect::index_out_of_range && defect != triangle_defect::repeated_index;
}
/// Well-formed with finite corners: the triangle takes part in area, volume and quality.
inline bool has_usable_geometry(triangle_defect defect) {
  return is_well_formed(defect) && defect != triangle_defect::bad_coordinate;
}

/// Finite and within max_analysed_coordinate on every axis.
bool usable_coordinate(const vec3& p);

triangle_defect classify_triangle(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& triangle);

/// classify_triangle for every triangle, in parallel.
std::vector<triangle_defect> classify_triangles(const surface_mesh& mesh);

/// Edge-ratio, angle statistics over the triangles with usable geometry. Leaves the edge-length fields at 0: they
/// count each edge once and come from measure_edge_lengths.
quality_report measure_triangle_quality(const surface_mesh& mesh, const std::vector<triangle_defect>& defects);

/// Sets quality.shortest_edge, median_edge and longest_edge from one length per edge (reorders `lengths`).
void measure_edge_lengths(std::vector<double>& lengths, quality_report& quality);

}  // namespace tracemesh::detail
