#pragma once
/// @file remesh_small_components.hpp
/// The quality pass's last step: closed components smaller than about two target edges (tiny cavities, mostly)
/// made again as star-shaped polyhedra.
///
/// The iterations cannot improve such a component: none of its edges is long enough to split, a collapse may not
/// leave it with fewer than 4 vertices, and most moves are refused because a polyhedron this coarse has faces
/// further than max_normal_deviation_deg from the field normals at its corners (a regular tetrahedron's faces are
/// 70.5° from its corners' directions). The component keeps the shape its raw mesh gave it, with edges far under
/// 0.1 × the median edge.
///
/// A component of genus 0 whose bounding box is at most max_diameter_in_edges × L across is made again:
/// - as n points of the surface on rays from its vertices' centroid, in directions spread evenly over the sphere (a
///   Fibonacci set, the best of a few fixed rotations), joined as the convex hull of those directions; n follows
///   the component's area and L, never more than it had. Each face must turn the same way about the centroid as its
///   directions do (the polyhedron is then star-shaped about the centroid, hence embedded);
/// - the better of that and the component as it is, by worst triangle, is then polished: a hill-climb of the
///   worst triangle's quality by vertex moves on the surface (the relaxation the iterations refused), up to 0.9;
/// - then lengthened: the same moves lengthen its shortest edges while every triangle stays that good. A tiny
///   cavity's edges are all short, and the targets ask for 0.1 × the median edge.
/// The result replaces the component only when its worst triangle is better, it passes the certificate's
/// orientation test (analysis_topology.hpp: component_normal_agreement) with no face folded against its corners'
/// normals (analysis_local_folds.hpp), and the certificate's own tests find none
/// of its triangles degenerate or meeting another triangle of the mesh (analysis_moved_triangles.hpp). When the
/// lengthened one fails those tests the polished one is tried: lengthened faces, chords of a longer stretch of
/// surface, may cross another sheet nearby where the polished ones do not.

#include <cstddef>

#include "core/field/gaussian_field.hpp"
#include "core/mesh.hpp"

namespace tracemesh::detail {

/// Replaces the small components of `mesh` as described above and returns how many were replaced. Precondition:
/// `mesh` is closed, oriented, manifold and free of self-intersections, with one field normal per vertex in
/// mesh.normals (kept up to date) and no atom_index. The other vertices and triangles keep their order; the new
/// ones come last. Deterministic: components are made independently and applied in order.
std::size_t resample_small_components(surface_mesh& mesh, const gaussian_field& field, double target_edge);

}  // namespace tracemesh::detail
