#pragma once
/// @file remesh.hpp
/// The quality pass: turns the valid but badly shaped marching-tetrahedra mesh of {φ = t0} into a well-shaped
/// mesh whose edges are close to a target length L, without ever losing validity (isotropic remeshing after
/// Botsch & Kobbelt, "A remeshing approach to multiresolution modeling", 2004, made safe).
///
/// Each outer iteration splits long edges, collapses short ones, flips edges towards valence 6 and moves every
/// vertex towards the centre of its 1-ring in the tangent plane; new and moved vertices are put back onto the
/// surface. The iterations stop early where the triangles already meet the quality targets (done_edge_ratio_mean).
/// Every operation is checked locally (link condition, normals against the field normal, shape). Local checks
/// cannot see two sheets of surface that come close, so validity rests on the certificate's own tests
/// (exact self-intersection, degeneracy), run on every result before it is kept:
/// - the mesh is cut into patches with a fixed boundary, remeshed in parallel and each checked against the fixed
///   triangles around it (remesh_chunks.hpp; a mesh under single_patch_triangles is one patch);
/// - a patch runs a round (tiny-edge sweep, iterations, final relaxation) on a copy; should the result be unclean,
///   the round restarts from the patch's input with the vertices near the offending triangles frozen (untouchable:
///   never moved, removed, nor given or deprived of an edge), until clean; at worst the patch comes back unchanged
///   (remesh_patch.hpp);
/// - last, closed components at most 2 L across (tiny cavities, which the iterations cannot reshape) are made again
///   as star-shaped polyhedra where that gives better triangles (remesh_small_components.hpp), then edges shorter
///   than final_collapse_below × L (left where patches stayed frozen, or in a cavity whose remake was refused) are
///   collapsed where the certificate's tests allow it (short_edge_collapse.hpp).
/// Deterministic: the same input gives the same output whatever the number of threads.

#include <cstddef>

#include "core/field/gaussian_field.hpp"
#include "core/limits.hpp"
#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"

namespace tracemesh {

struct remesh_options {
  double target_edge = 1.0;        ///< L, Å. The mesher derives it from the density: L = √(2 / (√3 · density)).
  /// Outer iterations of split / collapse / flip / relax; more cost far more time than they gain in edge ratio
  /// (docs/method.md, quality pass).
  int iterations = 3;
  /// The iterations end early, in each patch, once the triangles it may still change (a corner not frozen) have an
  /// edge-ratio mean of at least done_edge_ratio_mean and at most a share done_poor_share of them below 0.2; measured
  /// before each iteration, so that a patch already that good only has its final relaxation. 0.8: the floor
  /// for the refined mean, which the final relaxation then raises (above 1: never end early).
  double done_edge_ratio_mean = 0.8;
  double done_poor_share = 0.001;
  double split_above = 4.0 / 3.0;  ///< split edges longer than this × L
  double collapse_below = 4.0 / 5.0;  ///< collapse edges shorter than this × L (never creating one > split_above × L)
  double tiny_edge_below = 0.2;       ///< edges shorter than this × L are collapsed in a first, separate sweep
  /// Every new or moved triangle's normal must stay within this angle (degrees) of the field normal −∇φ/|∇φ|
  /// averaged over its three vertices: this is what keeps the mesh from folding.
  double max_normal_deviation_deg = 70.0;
  /// Shape quality q = 4√3·area / Σ edge² (1 = equilateral, 0 = degenerate). An operation may not create a triangle
  /// below min(quality_floor, worst quality among the triangles it replaces)...
  double quality_floor = 0.25;
  /// ...nor, whatever it replaces, one below this (keeps every triangle clearly non-degenerate).
  double hard_quality_floor = 1e-6;
  /// Å: every new or moved vertex ends within this first-order distance |φ − t0| / |∇φ| of the surface.
  double surface_tolerance = 1e-5;
  /// Extra tangential relaxation sweeps after the last iteration (a second one gains almost nothing).
  int final_relaxations = 1;
  /// After a failed round, vertices within freeze_radius × L of an offending triangle are frozen; the radius doubles
  /// with every further round.
  double freeze_radius = 1.0;
  /// When true and mesh.normals holds one unit normal per vertex, they are taken as the field normals −∇φ/|∇φ| of
  /// the input vertices instead of evaluating the field there (the mesher's root finder may already know them).
  bool trust_input_normals = false;
  int max_rounds = 6;  ///< rounds of a patch (see above) before giving up and returning it unchanged
  /// At the end, edges shorter than this × L are collapsed where safe: frozen regions keep the raw mesh's short
  /// edges, which would otherwise be the mesh's worst.
  double final_collapse_below = 0.15;
  /// A mesh of fewer triangles than this is remeshed as one patch whose round is not checked for self-intersections
  /// and inward components at its end, nor its result rebuilt to confirm it is a closed oriented manifold
  /// (remesh_stats::unchecked; vertices are still settled onto the surface, and the result's topology is still
  /// compared with the input's). For a caller that certifies the result anyway and runs
  /// the pass again, checked, should that fail: mesh_molecule. 0: every round is checked.
  std::size_t unchecked_below_triangles = 0;
  /// Edge of the chunks the mesh is cut into, in units of L (see remesh_chunks.hpp); at least 16. Twice the edge means
  /// about 8 times fewer patches, each doing more work per redo.
  double chunk_edges = 48;
  /// Meshes with fewer triangles are remeshed as one patch (no chunks).
  std::size_t single_patch_triangles = 100'000;
  std::size_t max_triangles = mesh_limits{}.max_triangles;  ///< errc::limit_exceeded when the output would exceed it
};

struct remesh_stats {
  // Operations kept in the final round.
  std::size_t splits = 0;
  std::size_t collapses = 0;
  std::size_t flips = 0;
  std::size_t relaxations = 0;      ///< accepted vertex moves
  std::size_t rejected_ops = 0;     ///< candidate operations refused by a local safety check
  std::size_t frozen_vertices = 0;  ///< output vertices left frozen (or input vertices, when the input is returned)
  int rounds = 0;                   ///< most rounds run in one patch (1 unless a round ended unclean)
  bool input_returned = false;      ///< true when no patch gave a clean result and the input was kept
  std::size_t patches = 0;            ///< patches remeshed (1 for a mesh remeshed whole)
  std::size_t unchanged_patches = 0;  ///< patches whose rounds all failed, left as they were
  std::size_t final_collapses = 0;    ///< short edges collapsed at the end (final_collapse_below)
  std::size_t remade_components = 0;  ///< small components made again (remesh_small_components.hpp)
  bool unchecked = false;  ///< the mesh was remeshed as one patch without the check (unchecked_below_triangles)
  /// Evaluations of φ and ∇φ, all rounds included (input normals, projections, relaxation steps; not the few of
  /// the small-component remakes).
  std::size_t field_evaluations = 0;
};

/// Improves `mesh` in place.
/// @param mesh     precondition: closed, edge- and vertex-manifold, consistently oriented (counter-clockwise seen
///                 from outside), no degenerate triangle, no self-intersection, no unreferenced vertex, vertices on
///                 {φ = t0}. Postcondition: the same properties, the same number of components and the same genus
///                 per component, every moved or new vertex within 1e-4 Å of the surface; mesh.normals
///                 (−∇φ/|∇φ|) filled for the final vertices, mesh.atom_index cleared (it is the caller's to fill:
///                 the mesher probes the field at every vertex for its certificate anyway).
/// @param field    the field whose surface {φ = field.t0()} the mesh approximates.
/// @param options  target edge length and thresholds (see remesh_options).
/// @param progress polled between sweeps and every few thousand operations (stage mesh_stage::refining).
/// @return the statistics, or: errc::invalid_argument (options out of range, or a mesh that is not a closed
///         oriented manifold), errc::limit_exceeded (output over options.max_triangles), errc::cancelled. On
///         errc::invalid_argument, and on any error of a mesh remeshed whole, its positions and triangles are left
///         unchanged (mesh.normals may hold the field normals); a chunked mesh stopped part-way (cancelled, too
///         many triangles) is left valid but partly remeshed (not copying a mesh of millions of triangles is worth
///         more than restoring it).
result<remesh_stats> remesh_surface(surface_mesh& mesh, const gaussian_field& field, const remesh_options& options,
                                    progress_token& progress);

}  // namespace tracemesh
