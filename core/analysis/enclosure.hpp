#pragma once
/// @file enclosure.hpp
/// Which components of a closed mesh lie inside another component (a molecule's inner cavities, and anything
/// inside those), and removing components (cavities=drop).
///
/// A component A is *enclosed* when a vertex of A is inside the closed surface of another component B: B's winding
/// number there is ±1 (±: whatever B's orientation), 0 outside. The components of a certified mesh do not
/// intersect, so one vertex decides for the whole component. Only components whose bounding box lies inside B's
/// are tested against B. The winding number is counted along a ray from the vertex parallel to x (the signed
/// number of B's triangles it crosses), for all of B's candidates in one pass over B's triangles with the vertices
/// bucketed on the yz plane: O(triangles of B + crossings) per enclosing B. The rays that meet an edge or a vertex
/// of B within a relative 1e-10 (common on the trace path, whose line roots share lines parallel to x) are cast
/// again together along a skewed direction; one degenerate both ways is decided by the generalised winding number
/// (the sum of the signed solid angles of B's triangles over 4π: no ray, hence no such case; O(triangles of B) per
/// point). Summing solid angles for every pair, as before, took 150 s of 203 on the 1,082,160-atom capsid (942
/// cavities inside the box of its outer surface, each tested against its 5 million triangles).

#include <cstdint>
#include <vector>

#include "core/analysis/mesh_analysis.hpp"
#include "core/mesh.hpp"

namespace tracemesh {

/// Per component of `report` (which must come from analyze_mesh(mesh) with analysis_options::label_vertices):
/// true when the component is enclosed by another one (see above).
std::vector<bool> enclosed_components(const surface_mesh& mesh, const mesh_report& report);

/// Removes the triangles of every component c with drop[c] (components and labels as in `vertex_component`, the
/// report's), and the vertices left unused; the remaining vertices keep their order, and normals and atom_index
/// (when present) follow their vertices. Returns the number of triangles removed.
std::size_t remove_components(surface_mesh& mesh, const std::vector<std::uint32_t>& vertex_component,
                              const std::vector<bool>& drop);

/// The generalised winding number of the triangles `triangles` of `mesh` at `point`: 1 (or −1, for inward-facing
/// triangles) inside a closed surface, 0 outside, fractional only near or on an open surface.
double winding_number(const surface_mesh& mesh, const std::vector<std::uint32_t>& triangles, const vec3& point);

}  // namespace tracemesh
