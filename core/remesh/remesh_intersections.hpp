#pragma once
/// @file remesh_intersections.hpp
/// Where a mesh would fail its certificate: the remesher needs the offending triangles themselves (not just their
/// number, as count_self_intersections in mesh_analysis.hpp gives) to know where to freeze the mesh. The tests are
/// those of the certificate, and so is the search: its grid for the pairs that share no vertex
/// (analysis_self_intersection.hpp) and its fan pass for the others (analysis_fan_pairs.hpp).

#include <array>
#include <cstdint>
#include <vector>

#include "core/analysis/analysis_fan_pairs.hpp"
#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_self_intersection.hpp"
#include "core/mesh.hpp"

namespace tracemesh::detail {

/// The triangles that would fail the certificate: those with a defect, both members of every intersecting pair
/// (`groups` as for find_intersecting_pairs, analysis_fan_pairs.hpp) and, when the mesh has one normal per vertex,
/// every triangle of a component oriented against its normals (find_inward_component_triangles). Sorted, without
/// repeats.
std::vector<std::uint32_t> find_offending_triangles(const surface_mesh& mesh,
                                                    const std::vector<std::uint8_t>& groups = {});

/// The triangles of the components that the certificate counts as inward oriented (component_normal_agreement not
/// positive); none when the mesh lacks one normal per vertex. The quality pass can make one: collapsing a tiny
/// cavity of a sharp kernel down to a flat tetrahedron can turn it inside out. Sorted.
std::vector<std::uint32_t> find_inward_component_triangles(const surface_mesh& mesh,
                                                           const std::vector<triangle_defect>& defects);

}  // namespace tracemesh::detail
