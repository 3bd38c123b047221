#pragma once
/// @file enclosure.hpp
/// Which components of a closed mesh lie inside another component (a molecule's inner cavities, and anything
/// inside those), and removing components (cavities=drop).
///
/// A component A is *enclosed* when a vertex of A is inside the closed surface of another component B: the
/// generalised winding number of B's triangles at that vertex (the sum of their signed solid angles over 4π;
/// ±1 inside a closed surface whatever its orientation, 0 outside) has magnitude above 1/2. The components of a
/// certified mesh do not intersect, so one vertex decides for the whole component, and the winding number needs no
/// ray, so no edge or vertex hit can make it ambiguous. Only components whose bounding box lies inside B's are
/// tested against B. Cost: O(triangles of B) per such pair, run in parallel over the components.

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
