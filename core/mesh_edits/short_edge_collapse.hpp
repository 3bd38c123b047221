#pragma once
/// @file short_edge_collapse.hpp
/// Collapsing a mesh's short edges where that is safe, checked by the certificate's own tests: the one mesh edit
/// that three steps of two stages share.
///
/// - The raw trace mesh (not part of the paper's method): where a line grazes the surface across a thin cap, the two
///   return arcs through its two roots (one in each plane through the line) bound a lens whose middle points lie
///   about the cap's height apart (1e-4 Å and less). Such an edge is harmless to the
///   certificate but not to what comes after: a Draco grid of 0.01 Å merges its ends, the quality pass keeps it
///   wherever it has to freeze the region, and a boundary-element solver stalls on it (method.md §8). Edges at an arc
///   point under h̃/100 are collapsed ("welded"), the arc point going; line roots are never moved or removed.
/// - The raw trace mesh delivered as it is (refine=none; not the paper's either): where a line meets the surface at a
///   grazing angle, the first points of its xy and xz arcs leave the root in nearly the same direction and lie close
///   together. Edges at an arc point under h̃/2 are collapsed the same way (trace_mesher.cpp).
/// - The quality pass: where a patch's rounds failed near two sheets of surface that come close, its vertices stay
///   frozen and keep the raw mesh's short edges. Edges under 0.15 L are collapsed at its end.
///
/// A collapse moves the removed end onto the kept one (the lower-numbered end, a vertex of the surface; or the other
/// one, when both may move and keeping the lower one is refused), so every vertex stays where it was.

#include <cstddef>
#include <cstdint>

#include "core/mesh.hpp"

namespace tracemesh {

/// What to do where a short edge's ends have a third common neighbour e (the link condition fails): leave the edge
/// (the raw trace mesh, whose triangles must stay those of its polygons), or first flip the edge from an end to e
/// (the quality pass), keeping the flip only when the certificate's tests pass it.
enum class blocked_links { left, flipped };

/// Components of this many vertices or fewer keep their edges (see collapse_short_edges).
inline constexpr std::uint32_t default_min_component_vertices = 8;

/// Collapses, shortest first, every edge of `mesh` shorter than `max_length` Å with an end numbered
/// `first_movable_vertex` or above (the vertices before it are never removed), where:
/// - its component keeps more than `min_component_vertices` vertices: 8 by default, as a tiny cavity is the quality
///   pass's to reshape whole (remesh_small_components.hpp; a collapse in the raw mesh can leave it a tetrahedron
///   with a short edge); the quality pass itself passes 4, after the cavities it could remake;
/// - exactly two triangles share the edge and their third corners differ, and each of those two corners keeps at
///   least three triangles (no pinch). A corner of only three triangles that may move is first merged into the
///   nearer end of the edge, or else the farther (its three triangles become one; the same conditions apply), then
///   the edge is tried again;
/// - the two ends have no common neighbour but those two corners (the link condition: the result stays manifold);
/// - no triangle of the removed end turns over or degenerates when that end moves onto the kept one, unless it
///   faced against the vertex normals at its corners (mesh.normals, when there is one per vertex) and then faces
///   along them: the move puts it right;
/// - no triangle of the removed end that faced along the vertex normals at some corner faces against all three after
///   the move (a fold, which the certificate refuses; the same holds for the flips of blocked_links::flipped);
/// - the certificate's own tests find none of the moved triangles degenerate or meeting another triangle (a
///   collapse that fails is undone with its round and the others made again, for a few rounds; in a pass of 10,000
///   edges or more, first alone with the later collapses that touched what it touched, its edges going to the next
///   pass).
/// The two triangles on the edge go, the removed end's others take the kept end instead, and the unused vertex is
/// dropped (the others keep their order, as do normals and atom indices when there is one per vertex).
/// Precondition: `mesh` is closed and oriented. Returns the edges collapsed.
std::size_t collapse_short_edges(surface_mesh& mesh, std::uint32_t first_movable_vertex, double max_length,
                                 std::uint32_t min_component_vertices = default_min_component_vertices,
                                 blocked_links links = blocked_links::left);

/// Flips each edge (c, d) whose two triangles' third corners a and b lie closer than `max_length` Å and than a tenth
/// of the edge, one of them numbered first_movable_vertex or above, into (a, b), so that collapse_short_edges can then
/// collapse it: for the raw trace mesh delivered as it is, where the two arcs beside a line that grazes the surface
/// pass close to it, one in each plane, and a cell's triangulation joined their points by the long diagonal of a pair
/// of slivers (a near-duplicate vertex pair: analysis_local_folds.hpp). A flip is made where the mesh stays manifold
/// and each new triangle faces along the vertex normals at its corners and is not folded, and kept where the
/// certificate's own tests pass its triangles; flips touch disjoint vertices. Precondition: as collapse_short_edges,
/// and one normal per vertex. Returns the flips kept.
std::size_t flip_to_short_diagonals(surface_mesh& mesh, std::uint32_t first_movable_vertex, double max_length);

/// Collapses edges of the triangles that face against the vertex normals at all three corners (folds, which the
/// certificate refuses: analysis_local_folds.hpp), shortest first, under the same conditions as collapse_short_edges
/// (a collapse makes no new fold; the folded triangles on the edge go), in up to a few passes. For the
/// marching-tetrahedra mesh, where a crevice narrower than the lattice is cut by triangles standing across it: no
/// rule of the tetrahedra can avoid them. Precondition: as collapse_short_edges, and one normal per vertex (else
/// nothing is done). Returns the edges collapsed.
std::size_t collapse_folded_triangles(surface_mesh& mesh, std::uint32_t first_movable_vertex);

}  // namespace tracemesh
