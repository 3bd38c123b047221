#pragma once
/// @file remesh_patch.hpp
/// The quality pass on one patch: a piece of a closed mesh (or the whole of it) whose boundary stays fixed. The
/// patch is remeshed in rounds (remesh.hpp, level 2): each round runs the tiny-edge sweep, the iterations and the
/// final relaxation, then checks the result as the certificate would, including against the fixed triangles
/// around the patch (its context); a round that fails restarts from the input with the vertices near the offending
/// triangles frozen. A patch whose rounds all fail comes back unchanged. The topology of every component (Euler
/// characteristic, boundary) is checked to be unchanged.
///
/// A patch stands alone: its result depends on its input, context, field and options only (not on threads).

#include <cstdint>
#include <vector>

#include "core/remesh/remesh_mesh.hpp"
#include "core/field/gaussian_field.hpp"
#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/remesh/remesh.hpp"
#include "core/status.hpp"

namespace tracemesh::detail {

/// A patch: vertices (with their field normals −∇φ/|∇φ|) and triangles, counter-clockwise seen from outside. The
/// vertices on its boundary (edges with one triangle here) are frozen, and so are those flagged in `frozen`.
struct remesh_patch_input {
  std::vector<vec3> positions;
  std::vector<vec3> normals;
  triangle_list triangles;
  std::vector<std::uint8_t> frozen;  ///< empty, or one flag per vertex
};

/// The fixed triangles around a patch that its new triangles may not cut. A corner c < (patch vertex count) is that
/// patch vertex (one of its boundary vertices, which never move); a larger one is positions[c − patch vertex count].
struct remesh_patch_context {
  std::vector<vec3> positions;
  triangle_list triangles;
  /// With `bounded`: the context holds every fixed triangle that meets `reach`, so a patch whose triangles leave it
  /// cannot be checked, and fails its check.
  bool bounded = false;
  box3 reach;
};

struct remesh_patch_output {
  surface_mesh mesh;                  ///< positions, normals and triangles (atom_index left empty)
  std::vector<std::uint32_t> origin;  ///< per output vertex: its input index, or no_index for a new vertex
  std::vector<std::uint8_t> frozen;   ///< per output vertex: whether it was frozen in the round kept
  remesh_stats stats;
};

/// Remeshes `input`. Errors: errc::invalid_argument (not an oriented manifold, options out of range),
/// errc::limit_exceeded (more than options.max_triangles triangles), errc::cancelled. With `report_stages`, the
/// fraction of stages done is reported (mesh_stage::refining); otherwise `progress` is only polled.
result<remesh_patch_output> remesh_patch(const remesh_patch_input& input, const remesh_patch_context& context,
                                         const gaussian_field& field, const remesh_options& options,
                                         progress_token& progress, bool report_stages = false);

/// Validates remesh_options; errc::invalid_argument naming the first bad field.
status check_remesh_options(const remesh_options& options);

}  // namespace tracemesh::detail
