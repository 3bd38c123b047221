#pragma once
/// @file remesh_chunks.hpp
/// The quality pass over a whole closed mesh, cut into chunks so that it runs in parallel, checks and redoes work
/// locally, and never copies the whole mesh.
///
/// Space is cut into cubic chunks of edge C = options.chunk_edges · L, each made of 12³ cells of natural size C/12.
/// A cell is at least twice the longest triangle edge, up to twice its natural size; a chunk of grown cells holds
/// fewer of them, down to 6³, so that C stays about the same. Triangles with an edge longer than half a cell are
/// never in a patch, only in contexts. A chunk's patch is every other triangle whose centroid lies in the chunk grown
/// by one cell on every side; the vertices that also have triangles outside the patch are its boundary and stay
/// frozen (remesh_patch.hpp). The growth makes every vertex an interior vertex of its own chunk's patch, so one pass
/// over the chunks reaches the whole surface, and the band along a chunk's faces is remeshed by both neighbours in
/// turn. Chunks are processed in 8 colours (the parities of their coordinates): the grown chunks of one colour are at
/// least 4 cells apart (10 with 12 cells a chunk), so their patches run in parallel without meeting; their results
/// are merged in chunk order after each colour. Every patch is checked against the triangles around it (its
/// context), so the mesh stays free of self-intersections throughout.
///
/// Deterministic: patches are extracted in index order, remeshed alone and merged in chunk order.
/// Memory: the mesh once (positions, normals, triangles, a cell index) plus one patch per worker.

#include "core/field/gaussian_field.hpp"
#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/remesh/remesh.hpp"
#include "core/status.hpp"

namespace tracemesh::detail {

/// Remeshes `mesh` (closed, oriented, manifold; mesh.normals the field normals of its vertices) in place:
/// positions, normals and triangles are replaced; atom_index is left alone. Errors: errc::invalid_argument (not a
/// closed oriented manifold: checked before anything changes), errc::limit_exceeded, errc::cancelled (the mesh
/// is then valid but partly remeshed).
result<remesh_stats> remesh_in_chunks(surface_mesh& mesh, const gaussian_field& field, const remesh_options& options,
                                      progress_token& progress);

}  // namespace tracemesh::detail
