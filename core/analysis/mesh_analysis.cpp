#include "core/analysis/mesh_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/analysis/analysis_fan_pairs.hpp"
#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_local_folds.hpp"
#include "core/analysis/analysis_self_intersection.hpp"
#include "core/analysis/analysis_topology.hpp"

namespace tracemesh {
namespace {

using detail::component_labels;
using detail::edge_census;
using detail::no_component;
using detail::triangle_defect;

/// Per-component accumulators, before they become a component_report.
struct component_sums {
  std::size_t vertices = 0;
  std::size_t edges = 0;
  std::size_t triangles = 0;
  double area = 0;
  double volume = 0;
};

void count_defects(const std::vector<triangle_defect>& defects, mesh_report& report) {
  for (const triangle_defect defect : defects) {
    if (defect == triangle_defect::index_out_of_range) {
      ++report.invalid_triangles;
    } else if (defect != triangle_defect::none) {
      ++report.degenerate_triangles;
    }
  }
}

std::size_t count_unreferenced_vertices(const surface_mesh& mesh) {
  std::vector<bool> referenced(mesh.positions.size(), false);
  for (const std::array<std::uint32_t, 3>& triangle : mesh.triangles) {
    for (const std::uint32_t v : triangle) {
      if (v < referenced.size()) referenced[v] = true;
    }
  }
  return static_cast<std::size_t>(std::count(referenced.begin(), referenced.end(), false));
}

/// Centre of the box of the usable vertex positions. Volumes are summed relative to it: the divergence-theorem
/// sum does not depend on the origin for closed components, and a nearby origin keeps the terms small.
vec3 volume_origin(const surface_mesh& mesh) {
  vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  vec3 hi = -lo;
  for (const vec3& p : mesh.positions) {
    if (!detail::usable_coordinate(p)) continue;
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
    }
  }
  return lo.x <= hi.x ? 0.5 * (lo + hi) : vec3{};
}

/// Sums vertices, edges, triangles, area and signed volume per component, in triangle order.
std::vector<component_sums> sum_components(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                           const component_labels& labels, const edge_census& census) {
  std::vector<component_sums> sums(labels.count);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    if (labels.of_vertex[v] == no_component) continue;
    ++sums[labels.of_vertex[v]].vertices;
    sums[labels.of_vertex[v]].edges += census.edges_at_smaller_end[v];  // each edge belongs to its smaller end
  }
  const vec3 origin = volume_origin(mesh);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (labels.of_triangle[t] == no_component) continue;
    component_sums& sum = sums[labels.of_triangle[t]];
    ++sum.triangles;
    if (!detail::has_usable_geometry(defects[t])) continue;
    const std::array<std::uint32_t, 3>& triangle = mesh.triangles[t];
    const vec3 a = mesh.positions[triangle[0]] - origin;
    const vec3 b = mesh.positions[triangle[1]] - origin;
    const vec3 c = mesh.positions[triangle[2]] - origin;
    const vec3 face_normal = cross(b - a, c - a);  // length = 2 × area
    sum.area += 0.5 * norm(face_normal);
    sum.volume += dot(a, cross(b, c)) / 6.0;  // signed volume of the tetrahedron (origin, a, b, c)
  }
  return sums;
}

component_report make_component_report(const component_sums& sum, std::size_t boundary_loops) {
  component_report component;
  component.vertices = sum.vertices;
  component.triangles = sum.triangles;
  component.area = sum.area;
  component.volume = sum.volume;
  component.euler_characteristic =
      static_cast<long>(sum.vertices) - static_cast<long>(sum.edges) + static_cast<long>(sum.triangles);
  component.boundary_loops = boundary_loops;
  component.genus = (2 - component.euler_characteristic - static_cast<long>(boundary_loops)) / 2;
  component.cavity = sum.volume < 0;
  return component;
}

/// Components whose orientation the supplied normals do not confirm (see mesh_report).
std::size_t count_inward_components(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                    const component_labels& labels) {
  if (mesh.normals.empty()) return 0;
  if (mesh.normals.size() != mesh.positions.size()) return labels.count;
  const std::vector<double> agreement = detail::component_normal_agreement(mesh, defects, labels);
  return static_cast<std::size_t>(std::count_if(agreement.begin(), agreement.end(), [](double a) { return !(a > 0); }));
}

/// The order of the components in the report: largest area first; equal areas keep label order (by first
/// triangle). NaN areas sort last.
std::vector<std::size_t> order_by_area(const std::vector<component_report>& components) {
  const auto key = [&](std::size_t c) {
    return std::isnan(components[c].area) ? -std::numeric_limits<double>::infinity() : components[c].area;
  };
  std::vector<std::size_t> order(components.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key(a) > key(b); });
  return order;
}

/// Per vertex, the index of its component in report.components (no_component for a vertex of no triangle).
std::vector<std::uint32_t> vertex_components(const component_labels& labels, const std::vector<std::size_t>& order) {
  std::vector<std::uint32_t> rank(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) rank[order[i]] = static_cast<std::uint32_t>(i);
  std::vector<std::uint32_t> of_vertex(labels.of_vertex.size(), no_component);
  for (std::size_t v = 0; v < of_vertex.size(); ++v) {
    if (labels.of_vertex[v] != no_component) of_vertex[v] = rank[labels.of_vertex[v]];
  }
  return of_vertex;
}

void add_components(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                    const component_labels& labels, const edge_census& census, bool label_vertices,
                    mesh_report& report) {
  const std::vector<component_sums> sums = sum_components(mesh, defects, labels, census);
  const std::vector<std::size_t> loops = detail::count_boundary_loops(census, labels);
  std::vector<component_report> components;
  for (std::size_t c = 0; c < sums.size(); ++c) {
    const component_report component = make_component_report(sums[c], loops[c]);
    report.area += component.area;
    report.volume += component.volume;
    report.euler_characteristic += component.euler_characteristic;
    report.genus += component.genus;
    if (component.cavity) ++report.cavities;
    components.push_back(component);
  }
  const std::vector<std::size_t> order = order_by_area(components);
  for (const std::size_t c : order) report.components.push_back(components[c]);
  if (label_vertices) report.vertex_component = vertex_components(labels, order);
  report.inward_oriented_components = count_inward_components(mesh, defects, labels);
}

/// All intersecting pairs: those sharing no vertex through the grid, the others fan by fan.
std::size_t count_intersecting_pairs(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                     const detail::vertex_fans& fans) {
  return detail::count_intersecting_separate_pairs(mesh, defects) +
         detail::count_intersecting_fan_pairs(mesh, defects, fans);
}

void add_topology_and_components(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                 const detail::vertex_fans& fans, bool label_vertices, mesh_report& report) {
  const component_labels labels = detail::label_components(mesh, defects);
  edge_census census = detail::take_edge_census(mesh, fans);
  report.boundary_edges = census.boundary_edges;
  report.non_manifold_edges = census.non_manifold_edges;
  report.non_manifold_vertices = census.non_manifold_vertices;
  report.inconsistently_oriented_edges = census.inconsistently_oriented_edges;
  add_components(mesh, defects, labels, census, label_vertices, report);
  detail::measure_edge_lengths(census.lengths, report.quality);
}

/// Triangle indices are 32-bit throughout the analysis.
bool too_many_triangles(const surface_mesh& mesh) { return mesh.triangles.size() >= no_component; }

}  // namespace

mesh_report analyze_mesh(const surface_mesh& mesh, const analysis_options& options) {
  mesh_report report;
  report.vertices = mesh.vertex_count();
  report.triangles = mesh.triangle_count();
  if (too_many_triangles(mesh)) {
    report.invalid_triangles = report.triangles;
    return report;
  }
  const std::vector<triangle_defect> defects = detail::classify_triangles(mesh);
  count_defects(defects, report);
  report.unreferenced_vertices = count_unreferenced_vertices(mesh);
  report.quality = detail::measure_triangle_quality(mesh, defects);
  const detail::vertex_fans fans = detail::build_vertex_fans(mesh, defects);
  add_topology_and_components(mesh, defects, fans, options.label_vertices, report);
  report.folded_triangles = detail::count_folded_triangles(mesh, defects);
  report.near_duplicate_vertex_pairs = detail::count_near_duplicate_vertex_pairs(mesh, fans);
  if (options.check_self_intersections) report.self_intersections = count_intersecting_pairs(mesh, defects, fans);
  report.achieved_density = report.area > 0 ? static_cast<double>(report.vertices) / report.area : 0.0;
  return report;
}

std::size_t count_degenerate_triangles(const surface_mesh& mesh) {
  const std::vector<triangle_defect> defects = detail::classify_triangles(mesh);
  return static_cast<std::size_t>(
      std::count_if(defects.begin(), defects.end(), [](triangle_defect d) { return d != triangle_defect::none; }));
}

std::size_t count_self_intersections(const surface_mesh& mesh) {
  if (too_many_triangles(mesh)) return 0;
  const std::vector<triangle_defect> defects = detail::classify_triangles(mesh);
  return count_intersecting_pairs(mesh, defects, detail::build_vertex_fans(mesh, defects));
}

}  // namespace tracemesh
