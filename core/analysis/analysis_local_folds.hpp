#pragma once
/// @file analysis_local_folds.hpp
/// Local defects that the topological certificate cannot see: a closed, manifold, oriented mesh without
/// self-intersections may still hold triangles turned over against the surface (a fold: the surface doubles back
/// within one triangle's width) and vertices of different sheets that nearly coincide. A boundary-element solver
/// stalls on both.

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/analysis/analysis_geometry.hpp"
#include "core/analysis/analysis_topology.hpp"
#include "core/mesh.hpp"

namespace tracemesh::detail {

/// Whether the triangle `t` faces against the outward surface normal at all three corners: the sign of
/// dot(cross(b − a, c − a), nᵢ) for each corner normal nᵢ (mesh.normals, −∇φ/|∇φ| at the vertex). Only the signs of
/// three dot products, with the normals the field gave at the vertices, so the test needs no field evaluation and
/// has no tolerance; a triangle that only crosses a crease (against one or two of its corners) is not a fold.
/// Precondition: one normal per vertex.
bool is_folded(const surface_mesh& mesh, const std::array<std::uint32_t, 3>& t);

/// mesh_report::folded_triangles: the triangles of usable geometry that is_folded; 0 unless there is one normal
/// per vertex.
std::size_t count_folded_triangles(const surface_mesh& mesh, const std::vector<triangle_defect>& defects);

/// mesh_report::near_duplicate_vertex_pairs: pairs of vertices that share no edge and lie closer than
/// near_duplicate_fraction × the shorter of their median incident edge lengths. Candidate pairs come from a grid
/// of cells about three median edges across (at least the largest such distance), its (cell, vertex) entries sorted so
/// that each cell's vertices are contiguous, cell by cell with the adjacent cells (with a vertex near enough to
/// them). Only vertices of well-formed triangles with usable coordinates take part.
std::size_t count_near_duplicate_vertex_pairs(const surface_mesh& mesh, const vertex_fans& fans);

/// Every pair (a, b), a < b, of vertices closer than `radius` Å, sorted, from the same grid with cells one radius
/// wide (for radius > 0 and finite coordinates).
std::vector<std::pair<std::uint32_t, std::uint32_t>> vertex_pairs_closer_than(const surface_mesh& mesh, double radius);

}  // namespace tracemesh::detail
