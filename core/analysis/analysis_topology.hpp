#pragma once
/// @file analysis_topology.hpp
/// Connectivity for mesh_analysis, using well-formed triangles only (see analysis_geometry.hpp):
/// - the triangles around each vertex (compressed rows, built by counting: no hash or tree maps);
/// - an edge census: every edge is found exactly once, at its smaller vertex, by sorting the few half-edges around
///   that vertex; together with the check that each vertex's triangles form one edge-connected fan;
/// - connected components (triangles joined through shared vertices) and their boundary loops.
/// Memory O(vertices + triangles); the per-vertex work runs in parallel with deterministic output.

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "core/analysis/analysis_geometry.hpp"
#include "core/mesh.hpp"

namespace tracemesh::detail {

/// Label of ill-formed triangles and of vertices that belong to no well-formed triangle.
inline constexpr std::uint32_t no_component = std::numeric_limits<std::uint32_t>::max();

/// The well-formed triangles around each vertex, in increasing triangle order.
struct vertex_fans {
  std::vector<std::size_t> offsets;      ///< vertex v owns triangles[offsets[v] .. offsets[v + 1])
  std::vector<std::uint32_t> triangles;  ///< triangle indices

  std::span<const std::uint32_t> around(std::size_t vertex) const {
    return {triangles.data() + offsets[vertex], offsets[vertex + 1] - offsets[vertex]};
  }
};

vertex_fans build_vertex_fans(const surface_mesh& mesh, const std::vector<triangle_defect>& defects);

/// A triangle seen from one of its corners v: counter-clockwise it runs v → next → prev.
struct fan_corner {
  std::uint32_t next, prev;
};

/// The triangles `around` vertex v, seen from v (replaces the contents of `corners`).
void read_fan_corners(const surface_mesh& mesh, std::uint32_t vertex, std::span<const std::uint32_t> around,
                      std::vector<fan_corner>& corners);

/// True when the triangles form one closed cycle around their vertex, each edge (vertex, x) shared by exactly two
/// of them in opposite directions: a closed, manifold, consistently oriented fan (a disk around an interior
/// vertex). Allocation-free scans for the usual small fans, O(k log k) for fans of k > 16 triangles.
bool corners_form_one_cycle(const std::vector<fan_corner>& corners);

using edge_key = std::array<std::uint32_t, 2>;  ///< (smaller vertex, larger vertex)

struct edge_census {
  std::size_t boundary_edges = 0;                   ///< edges of one triangle
  std::size_t non_manifold_edges = 0;               ///< edges of three or more triangles
  std::size_t inconsistently_oriented_edges = 0;    ///< edges of two triangles that traverse them the same way
  std::size_t non_manifold_vertices = 0;            ///< vertices whose triangles form more than one fan
  std::vector<std::uint32_t> edges_at_smaller_end;  ///< per vertex v: how many edges (v, w) have w > v
  std::vector<edge_key> boundary;                   ///< the boundary edges, in increasing order
  std::vector<double> lengths;  ///< Å, one per edge whose ends have usable coordinates, grouped by smaller end
};

edge_census take_edge_census(const surface_mesh& mesh, const vertex_fans& fans);

struct component_labels {
  std::size_t count = 0;                   ///< labels are 0 … count − 1, numbered by first triangle
  std::vector<std::uint32_t> of_triangle;  ///< no_component for ill-formed triangles
  std::vector<std::uint32_t> of_vertex;    ///< no_component for vertices of no well-formed triangle
};

component_labels label_components(const surface_mesh& mesh, const std::vector<triangle_defect>& defects);

/// Per component label: Σ over its triangles of usable geometry of dot(unnormalised face normal, sum of its three
/// vertex normals). A component whose sum is not positive is oriented against its normals
/// (mesh_report::inward_oriented_components). Precondition: one normal per vertex.
std::vector<double> component_normal_agreement(const surface_mesh& mesh, const std::vector<triangle_defect>& defects,
                                               const component_labels& labels);

/// Per component label: the number of connected chains of boundary edges (holes).
std::vector<std::size_t> count_boundary_loops(const edge_census& census, const component_labels& labels);

}  // namespace tracemesh::detail
