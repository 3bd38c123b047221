#pragma once
/// @file short_edge_welding.hpp
/// Welding of the raw trace mesh's hair-short edges between two arc points (not part of the paper's method).
///
/// Where a line grazes the surface across a thin cap, the two return arcs through its two roots (one in each plane
/// through the line) bound a lens whose middle points lie about the cap's height apart: 1e-4 Å and less on
/// 3j6r_asu at 1 v/Å². Such an edge is harmless to the certificate but not to what comes after: a Draco grid of
/// 0.01 Å merges its ends (the raw mesh could not be delivered as Draco or GLB), the quality pass keeps it wherever
/// it has to freeze the region, and a boundary-element solver stalls on it (method.md §8). An edge between two arc
/// points shorter than a small fraction of h̃ is therefore collapsed onto its lower-numbered end, when the collapse
/// keeps the mesh a closed, oriented manifold and turns no triangle over. Line roots are never moved or removed.

#include <cstdint>
#include <cstddef>

#include "core/mesh.hpp"

namespace tracemesh {

/// Collapses, shortest first, every edge of `mesh` shorter than `max_length` Å whose two ends are arc points
/// (vertices numbered `first_arc_point` or above; the roots come first), where:
/// - its component keeps at least 8 vertices (a tiny cavity is the quality pass's to reshape whole);
/// - exactly two triangles share the edge and their third corners differ, and each of those two corners keeps at
///   least three triangles (no pinch);
/// - the two ends have no common neighbour but those two corners (the link condition: the result stays manifold);
/// - no triangle of the removed end turns over or degenerates when that end moves onto the kept one.
/// The two triangles on the edge go, the removed end's others take the kept end instead, and the unused vertex is
/// dropped (the others keep their order). Precondition: `mesh` is closed and oriented. Returns the edges collapsed.
std::size_t weld_short_arc_edges(surface_mesh& mesh, std::uint32_t first_arc_point, double max_length);

}  // namespace tracemesh
