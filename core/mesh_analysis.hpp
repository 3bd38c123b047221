#pragma once
/// @file mesh_analysis.hpp
/// Measures a triangle mesh: size, area, volume, components (cavities), topology, manifoldness,
/// self-intersections and triangle quality. This is the per-job report; the certificate is derived from it.

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
  long euler_characteristic = 0;
  long genus = 0;         ///< (2 − χ)/2 for a closed orientable component
  bool cavity = false;    ///< true when volume < 0: an inner cavity of the molecule
};

struct quality_report {
  double edge_ratio_mean = 0;     ///< mean over triangles of shortest/longest edge
  double edge_ratio_min = 0;
  std::array<std::size_t, 10> edge_ratio_histogram{};  ///< bins [0,0.1), …, [0.9,1.0]
  double fraction_below_0_2 = 0;  ///< fraction of triangles with edge ratio < 0.2
  double min_angle_deg = 0;       ///< smallest interior angle of any triangle, degrees
  double shortest_edge = 0;       ///< Å
  double median_edge = 0;         ///< Å
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
  std::size_t non_manifold_vertices = 0;  ///< vertices whose triangle fan is not a single disk
  std::size_t inconsistently_oriented_edges = 0;  ///< interior edges traversed twice in the same direction
  std::size_t degenerate_triangles = 0;  ///< zero area, repeated vertex indices, or an edge < 1e-9 Å
  std::size_t unreferenced_vertices = 0;
  std::size_t self_intersections = 0;   ///< pairs of non-adjacent triangles that intersect
  std::size_t inward_oriented_components = 0;  ///< components whose normals disagree with the supplied vertex normals
  double achieved_density = 0;          ///< vertices per Å² of area
  quality_report quality;

  /// Closed, edge- and vertex-manifold, consistently oriented, no degenerate triangles, no self-intersections.
  bool topologically_certified() const {
    return triangles > 0 && boundary_edges == 0 && non_manifold_edges == 0 && non_manifold_vertices == 0 &&
           inconsistently_oriented_edges == 0 && degenerate_triangles == 0 && unreferenced_vertices == 0 &&
           self_intersections == 0 && inward_oriented_components == 0;
  }
};

struct analysis_options {
  bool check_self_intersections = true;
};

/// Analyses `mesh`. When mesh.normals is filled, each component's face orientation is compared with those
/// normals (inward_oriented_components counts disagreements). Runs in parallel; deterministic.
mesh_report analyze_mesh(const surface_mesh& mesh, const analysis_options& options = {});

/// Only the self-intersection test: pairs of triangles sharing no vertex that intersect, plus pairs sharing exactly
/// one vertex whose interiors overlap. Grid-accelerated; a few seconds for 10⁷ triangles.
std::size_t count_self_intersections(const surface_mesh& mesh);

}  // namespace tracemesh
