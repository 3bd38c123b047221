#pragma once
/// @file remesh_operations.hpp
/// The four sweeps of isotropic remeshing (split, collapse, flip, tangential relaxation) over a remesh_mesh, each
/// operation guarded by local checks so that the mesh stays a closed oriented manifold of unchanged topology whose
/// triangles follow the surface normal and never degenerate. Vertex protection (remesh_mesh.hpp) is respected.
///
/// Splits, collapses and flips run sequentially in half-edge order; relaxation runs in parallel over a greedy
/// vertex colouring (no two neighbours move at once). Everything is deterministic whatever the thread count.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/remesh/remesh_mesh.hpp"
#include "core/field/gaussian_field.hpp"
#include "core/progress.hpp"

namespace tracemesh::detail {

/// Absolute thresholds derived from remesh_options and the target edge L.
struct remesh_thresholds {
  double split_above = 0;              ///< Å: split longer edges
  double collapse_below = 0;           ///< Å: collapse shorter edges
  double tiny_below = 0;               ///< Å: first sweep collapses edges shorter than this
  double max_edge_after_collapse = 0;  ///< Å: a collapse may not create a longer edge
  double min_normal_cosine = 0;  ///< cosine of the largest angle between a new face's normal and its vertex normals
  double quality_floor = 0;      ///< see remesh_options::quality_floor
  double hard_quality_floor = 0;
  double max_move = 0;           ///< Å: largest move of a point onto the surface
  double surface_tolerance = 0;  ///< Å: new and moved vertices end within this first-order distance of the surface
};

struct operation_counts {
  std::size_t splits = 0, collapses = 0, flips = 0, relaxations = 0, rejected = 0;
  std::size_t field_evaluations = 0;  ///< φ and ∇φ evaluations (projections, relaxation steps)
};

class remesh_operations {
 public:
  /// `progress` is only polled for cancellation; every sweep returns false once it is cancelled.
  remesh_operations(remesh_mesh& mesh, const gaussian_field& field, const remesh_thresholds& thresholds,
                    const progress_token& progress);

  /// Splits every edge longer than thresholds.split_above at its midpoint projected onto the surface.
  bool split_long_edges();
  /// Collapses edges shorter than `shorter_than` (Å) onto one of their end points, whichever leaves the better
  /// triangles (the kept vertex is on the surface with its normal known: no field evaluation), else onto the
  /// projected midpoint.
  bool collapse_short_edges(double shorter_than);
  /// Flips edges whose flip brings the valences of the four vertices involved closer to 6.
  bool flip_edges_for_valence();
  /// Moves each free vertex to the area-weighted centroid of its 1-ring within the tangent plane, then one Newton
  /// step towards the surface (second-order close; settle_vertices finishes the projection).
  bool relax_vertices();
  /// Projects every vertex the edits placed onto the surface to thresholds.surface_tolerance (a tiny move after
  /// relaxation, whatever its protection since), refreshing its normal. Returns the vertices that could not be
  /// projected (normally none), and the projected corners of any triangle the projections folded (is_folded: no
  /// edit makes one, and neither may this). Parallel.
  std::vector<std::uint32_t> settle_vertices();

  /// The operations made, and the field evaluations they took.
  operation_counts counts() const;

 private:
  /// A triangle with the field normals at its corners.
  struct oriented_triangle {
    std::array<vec3, 3> p;
    std::array<vec3, 3> n;
  };
  /// What the acceptance test needs of a triangle, all from one cross product.
  struct triangle_shape {
    double quality;    ///< triangle_quality: 1 equilateral, 0 degenerate
    vec3 unit_normal;  ///< zero for a degenerate triangle
    double agreement;  ///< worst cosine between unit_normal and the corner normals (0 for a degenerate triangle)
    /// Whether the face points against every corner normal (detail::is_folded: the certificate refuses it).
    bool folded;
  };
  /// What a new triangle may not be worse than: see acceptable().
  struct replaced_triangle {
    double quality;    ///< worst shape quality among the triangles replaced (the bound is min(floor, this))
    double agreement;  ///< the replaced triangle's agreement with its normals (see agreement())
    vec3 normal;       ///< its unit normal when its shape makes it meaningful, else zero
  };

  bool try_split(std::uint32_t h);
  bool try_collapse(std::uint32_t h);
  /// Checks the faces of `removed` (adjacent to `kept`; faces f0 and f1 vanish) when it merges into `kept` placed at
  /// p with normal n; returns the worst new triangle quality, or a negative value when that is not acceptable.
  double collapse_outcome(std::uint32_t kept, const vec3& p, const vec3& n, std::uint32_t removed, std::uint32_t f0,
                          std::uint32_t f1, const std::vector<std::uint32_t>& removed_ring);
  bool try_flip(std::uint32_t h, std::vector<int>& valences);
  /// Moves p to within `tolerance` Å (first order) of the surface and sets n to the field normal there; false when
  /// that fails.
  bool project(vec3& p, vec3& n, double tolerance) const;
  /// project() for a vertex a split or a collapse creates (see edit_surface_tolerance).
  bool project_new_vertex(vec3& p, vec3& n) const;
  /// The face of h, starting at from(h).
  oriented_triangle triangle_of(std::uint32_t h) const;
  static triangle_shape shape_of(const oriented_triangle& t);
  static replaced_triangle replaced(const triangle_shape& t, double worst_quality);
  /// May `t` replace `old`? Its quality must reach min(quality_floor, old.quality) (and the hard floor), its normal
  /// must agree with the field normals at its corners at least as well as min(max deviation, old.agreement)
  /// allows and, unless `t` is a sliver or a `small_change` (a move under tiny_below), within 90°; it may not
  /// flip against old.normal.
  bool acceptable(const triangle_shape& t, const replaced_triangle& old, bool small_change = false) const;
  bool stop_requested(std::size_t step) const;
  /// Whether a sweep handles the edge of h at h: a live interior edge, visited once (at its larger half-edge).
  bool visits_edge(std::uint32_t h) const;
  /// A free vertex's relaxed position, or false when it should stay.
  bool relaxed_position(std::uint32_t v, vec3& position, vec3& normal) const;

  remesh_mesh& mesh_;
  const gaussian_field& field_;
  remesh_thresholds thresholds_;
  const progress_token& progress_;
  operation_counts counts_;
  mutable std::atomic<std::size_t> field_evaluations_{0};  ///< counted by parallel sweeps too
  std::vector<std::uint32_t> ring_a_, ring_b_;  // scratch
  std::vector<triangle_shape> fan_shapes_;      // scratch of collapse_outcome
  double settled_move2_;  ///< Å²: relaxation moves shorter than this are skipped
};

/// Greedy colouring of the free vertices in index order (no two adjacent vertices share a colour); the vertices
/// of each colour, ascending. Locked, frozen and removed vertices get no colour.
std::vector<std::vector<std::uint32_t>> colour_free_vertices(const remesh_mesh& mesh);

}  // namespace tracemesh::detail
