#pragma once
/// @file remesh_stages.hpp
/// The first level of the remesher's safety (see remesh.hpp): each stage of the pass (a sweep of operations) runs
/// on a copy of the mesh that is kept only when the certificate would accept it. When it would not, the vertices
/// near the offending triangles are frozen and the stage is redone with a growing radius, or skipped. A skipped
/// stage leaves the mesh exactly as it was: clean. Stages that are not checked (see stage_limits) edit the mesh in
/// place; the check at the end of the round covers them (remesh_patch.hpp).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/remesh/remesh_mesh.hpp"
#include "core/remesh/remesh_operations.hpp"
#include "core/field/gaussian_field.hpp"
#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"

namespace tracemesh::detail {

/// A stage: edits `mesh` (through `ops`, or directly for tests), respecting vertex protection. Returns false when
/// cancelled.
using remesh_stage = std::function<bool(remesh_mesh& mesh, remesh_operations& ops)>;

/// The mesh of a failed check and its offending triangles (sorted).
struct check_failure {
  surface_mesh mesh;
  std::vector<std::uint32_t> offending;
};

struct stage_limits {
  std::size_t max_triangles = 0;  ///< errc::limit_exceeded beyond
  double freeze_radius = 0;       ///< Å, first try; doubles with every further try
  int max_retries = 4;            ///< tries after the first before the stage is skipped
  /// When false, only settling stages are checked (the others are kept unchecked): cheaper, and enough where a
  /// failed check redoes a whole small patch (remesh_patch.hpp).
  bool check_every_stage = true;
};

/// The triangles of `view` (the compacted `mesh`) that would fail the certificate; find_offending_triangles by
/// default, or that plus the pairs with the fixed triangles around a patch.
using offending_finder = std::function<std::vector<std::uint32_t>(const remesh_mesh& mesh, const surface_mesh& view)>;

class verified_stages {
 public:
  verified_stages(const gaussian_field& field, const remesh_thresholds& thresholds, const stage_limits& limits,
                  progress_token& progress, offending_finder finder = {});

  /// Runs `stage` (then, when `settle`, settle_vertices()) on copies of `state` until one passes the certificate's
  /// tests (degenerate triangles, exact self-intersection, unsettled vertices), freezing the vertices of `state`
  /// near the offending triangles between tries. Returns true when `state` took the clean copy, false when the
  /// stage was skipped (`state` unchanged but for the frozen flags; last_failure() tells why); errc::cancelled or
  /// errc::limit_exceeded. A stage that is not checked (neither `settle` nor limits.check_every_stage) runs on
  /// `state` itself, which an error then leaves partly edited.
  result<bool> run(remesh_mesh& state, const remesh_stage& stage, bool settle);

  /// Operations of the kept copies.
  const operation_counts& counts() const { return counts_; }
  std::size_t retried_stages() const { return retried_; }
  /// Field evaluations of every try, kept or not.
  std::size_t field_evaluations() const { return field_evaluations_; }
  const check_failure& last_failure() const { return failure_; }

 private:
  const gaussian_field& field_;
  remesh_thresholds thresholds_;
  stage_limits limits_;
  progress_token& progress_;
  offending_finder finder_;
  operation_counts counts_;
  std::size_t retried_ = 0;
  std::size_t field_evaluations_ = 0;
  check_failure failure_;
};

/// The compacted `mesh` as the certificate sees it (positions, normals, triangles).
surface_mesh certificate_view(const remesh_mesh& mesh);

/// Sets frozen[v] for every point v within `radius` Å (at least: boxes are used) of a `listed` triangle of
/// `triangles` (over `triangle_positions`). Returns how many points became frozen.
std::size_t freeze_near(const std::vector<vec3>& points, const std::vector<vec3>& triangle_positions,
                        const triangle_list& triangles, const std::vector<std::uint32_t>& listed, double radius,
                        std::vector<std::uint8_t>& frozen);

/// Makes the `frozen` vertices frozen and their other neighbours locked (see vertex_protection).
void protect(remesh_mesh& mesh, const std::vector<std::uint8_t>& frozen);

/// frozen[v] = whether vertex v of `mesh` is frozen.
std::vector<std::uint8_t> frozen_flags(const remesh_mesh& mesh);

}  // namespace tracemesh::detail
