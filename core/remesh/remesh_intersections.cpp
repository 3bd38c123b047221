#include "core/remesh/remesh_intersections.hpp"

#include <algorithm>

#include "core/analysis/analysis_fan_pairs.hpp"
#include "core/analysis/analysis_self_intersection.hpp"
#include "core/analysis/analysis_topology.hpp"

namespace tracemesh::detail {

std::vector<std::uint32_t> find_offending_triangles(const surface_mesh& mesh, const std::vector<std::uint8_t>& groups) {
  const std::vector<triangle_defect> defects = classify_triangles(mesh);
  std::vector<std::uint32_t> offending;
  for (std::uint32_t t = 0; t < defects.size(); ++t) {
    if (defects[t] != triangle_defect::none) offending.push_back(t);
  }
  for (const triangle_pair& pair : find_intersecting_pairs(mesh, defects, groups)) {
    offending.insert(offending.end(), pair.begin(), pair.end());
  }
  const std::vector<std::uint32_t> inward = find_inward_component_triangles(mesh, defects);
  offending.insert(offending.end(), inward.begin(), inward.end());
  std::sort(offending.begin(), offending.end());
  offending.erase(std::unique(offending.begin(), offending.end()), offending.end());
  return offending;
}

std::vector<std::uint32_t> find_inward_component_triangles(const surface_mesh& mesh,
                                                           const std::vector<triangle_defect>& defects) {
  if (mesh.normals.size() != mesh.positions.size() || mesh.triangles.empty()) return {};
  const component_labels labels = label_components(mesh, defects);
  const std::vector<double> agreement = component_normal_agreement(mesh, defects, labels);
  std::vector<std::uint32_t> triangles;
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::uint32_t c = labels.of_triangle[t];
    if (c != no_component && !(agreement[c] > 0)) triangles.push_back(t);
  }
  return triangles;
}

}  // namespace tracemesh::detail
