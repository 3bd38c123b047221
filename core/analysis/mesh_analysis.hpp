#pragma once
/// @file mesh_analysis.hpp
/// Measures a triangle mesh: size, area, volume, components (cavities), topology, manifoldness,
/// self-intersections and triangle quality. This is the per-job report; the certificate is derived from it.
///
/// Vocabulary used below:
/// - a triangle is *ill-formed* when an index is ≥ the vertex count (counted in invalid_triangles) or two of its
///   indices are equal (counted in degenerate_triangles). Ill-formed triangles take no part in topology
///   (edges, fans, components, χ) or geometry.
/// - a triangle is *degenerate* when it repeats an index, has a corner that is not finite or beyond
///   max_analysed_coordinate, has an edge shorter than degenerate_edge_length, or has area below
///   degenerate_area_ratio · (longest edge)². Well-formed degenerate triangles still count in topology; those with
///   finite corners count in area, volume and quality; none of them is tested for self-intersection.
/// - components connect triangles through shared vertices (so two cones touching at their tips form one).
///
/// Cost: O(triangles) memory (about 100 bytes per triangle at the peak, on top of the mesh). Measured on a
/// 5.2 M-triangle icosphere: count_self_intersections ≈ 0.55 µs and analyze_mesh ≈ 0.8 µs of CPU time per
/// triangle, spread over the threads of the caller's TBB arena (a few parts are sequential). Deterministic: the
/// same mesh gives the bitwise same report whatever the thread count. Never throw on bad input (only
/// std::bad_alloc when memory runs out). Precondition: fewer than 2³² − 1 triangles (a larger mesh is reported as
/// all-invalid).

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh.hpp"

namespace tracemesh {

struct component_report {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  double area = 0;        ///< Å²
  double volume = 0;      ///< Å³, signed: > 0 for an outer surface, < 0 for a cavity (normals point into it)
  long euler_characteristic = 0;  ///< V − E + F of the component
  long genus = 0;         ///< (2 − χ − boundary_loops)/2: (2 − χ)/2 when closed; meaningful for manifold components
  bool cavity = false;    ///< true when volume < 0: an inner cavity of the molecule
  /// Inside another component's closed surface (analysis/enclosure.hpp). Not set by analyze_mesh: the mesher
  /// fills it (every cavity is enclosed; so is a component inside a cavity, whose volume is positive).
  bool enclosed = false;
  std::size_t boundary_loops = 0;  ///< connected chains of boundary edges (0 for a closed component)
};

/// Triangle statistics over the well-formed triangles with finite corners (degenerate ones included: they pull
/// the minima to 0); every field is 0 for a mesh without such triangles.
struct quality_report {
  double edge_ratio_mean = 0;     ///< mean over triangles of shortest/longest edge
  double edge_ratio_min = 0;
  std::array<std::size_t, 10> edge_ratio_histogram{};  ///< bins [0,0.1), …, [0.9,1.0]
  double fraction_below_0_2 = 0;  ///< fraction of triangles with edge ratio < 0.2
  double min_angle_deg = 0;       ///< smallest interior angle of any triangle, degrees
  double shortest_edge = 0;       ///< Å; each edge counted once
  double median_edge = 0;         ///< Å; mean of the two middle lengths when the edge count is even
  double longest_edge = 0;        ///< Å
};

struct mesh_report {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  double area = 0;          ///< Å²
  double volume = 0;        ///< Å³, enclosed (outer volumes minus cavities)
  std::vector<component_report> components;  ///< largest area first
  std::size_t cavities = 0;
  long euler_characteristic = 0;
  long genus = 0;           ///< sum of component genera
  std::size_t boundary_edges = 0;       ///< edges with one triangle
  std::size_t non_manifold_edges = 0;   ///< edges with more than two triangles
  std::size_t non_manifold_vertices = 0;  ///< vertices whose triangles do not form one edge-connected fan
  std::size_t inconsistently_oriented_edges = 0;  ///< edges of two triangles traversed twice in the same direction
  std::size_t degenerate_triangles = 0;  ///< repeated index, non-finite corner, edge < 1e-9 Å or zero area
  std::size_t invalid_triangles = 0;     ///< triangles with a vertex index ≥ vertices (ignored everywhere else)
  std::size_t unreferenced_vertices = 0;  ///< vertices that no triangle refers to
  std::size_t self_intersections = 0;   ///< intersecting triangle pairs (see count_self_intersections)
  /// Components whose face orientation does not agree with the supplied vertex normals: the sum over their
  /// triangles of dot(unnormalised face normal, n₀ + n₁ + n₂) is not positive. When mesh.normals is non-empty but
  /// not one per vertex, every component counts. 0 when mesh.normals is empty.
  std::size_t inward_oriented_components = 0;
  /// Triangles of usable geometry that face against the supplied vertex normals at all three corners (see
  /// detail::is_folded): the surface turned over within a triangle, where a boundary-element solver stalls. 0 when
  /// mesh.normals is not one per vertex.
  std::size_t folded_triangles = 0;
  /// Pairs of vertices sharing no edge that lie closer than near_duplicate_fraction × the shorter of their median
  /// incident edge lengths: two sheets of the mesh almost touching. Reported, not part of the certificate.
  std::size_t near_duplicate_vertex_pairs = 0;
  double achieved_density = 0;          ///< vertices per Å² of area (0 when the area is 0)
  quality_report quality;
  /// With analysis_options::label_vertices (else empty): per vertex, the index in `components` of the component
  /// it belongs to; 2³² − 1 for a vertex that no well-formed triangle uses.
  std::vector<std::uint32_t> vertex_component;

  /// Closed, edge- and vertex-manifold, consistently oriented, no degenerate or invalid triangles, no unused
  /// vertex, no self-intersections, and (when normals are supplied) faces oriented like the normals. Folds are
  /// counted, not tested here: the mesher refuses them where its path guarantees none (mesher.cpp).
  bool topologically_certified() const {
    return triangles > 0 && boundary_edges == 0 && non_manifold_edges == 0 && non_manifold_vertices == 0 &&
           inconsistently_oriented_edges == 0 && degenerate_triangles == 0 && invalid_triangles == 0 &&
           unreferenced_vertices == 0 && self_intersections == 0 && inward_oriented_components == 0;
  }
};

struct analysis_options {
  bool check_self_intersections = true;  ///< false leaves self_intersections at 0 (the test dominates the cost)
  bool label_vertices = false;           ///< true fills mesh_report::vertex_component
};

/// An edge shorter than this (Å) makes its triangle degenerate.
inline constexpr double degenerate_edge_length = 1e-9;
/// A triangle whose area is below this times its longest edge squared is degenerate (its corners are collinear
/// to within rounding: exactly collinear corners give a computed area of about 1e-16 · longest²).
inline constexpr double degenerate_area_ratio = 1e-12;
/// Corners beyond this |coordinate| (Å) make a triangle degenerate: the intersection test keeps single-precision
/// bounding boxes and cubes coordinate differences, which must stay finite. Meshes within limits.hpp stay far below.
inline constexpr double max_analysed_coordinate = 1e30;
/// Two vertices sharing no edge are near duplicates when closer than this times the shorter of their median incident
/// edges. Far below any edge the engine keeps (the quality pass collapses edges under 0.15 of its target length, the
/// raw trace mesh those under half its line spacing, about 0.5 of its median edge), so on a sound mesh two vertices
/// this close are never neighbours by accident: they sit on two sheets that touch, or on a fold.
inline constexpr double near_duplicate_fraction = 0.1;

/// Analyses `mesh` (see the vocabulary above). When mesh.normals is non-empty, each component's face orientation
/// is compared with those normals. Components are sorted by decreasing area, ties by their first triangle.
mesh_report analyze_mesh(const surface_mesh& mesh, const analysis_options& options = {});

/// mesh_report::degenerate_triangles + invalid_triangles alone: O(triangles), no topology.
std::size_t count_degenerate_triangles(const surface_mesh& mesh);

/// Counts pairs of non-degenerate, well-formed triangles that intersect, each pair once, with exact predicates:
/// - pairs sharing no vertex: any common point (touching counts);
/// - pairs sharing exactly one vertex: a common point other than that vertex;
/// - pairs sharing an edge: folding onto each other (coplanar, on the same side of the edge);
/// - pairs sharing all three vertices (duplicated faces): always.
/// Pairs that share no vertex are found through a uniform grid over the triangles' bounding boxes; pairs that
/// share vertices are examined vertex by vertex, where most fans are proved intersection-free as a whole.
std::size_t count_self_intersections(const surface_mesh& mesh);

}  // namespace tracemesh
