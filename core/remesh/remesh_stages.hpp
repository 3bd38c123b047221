#pragma once
/// @file remesh_stages.hpp
/// The stages of a remesher round (see remesh.hpp): each sweep of operations edits the patch's mesh in place; the
/// last, settling stage also checks the result as the certificate would, and its offending triangles tell the next
/// round which vertices to freeze (remesh_patch.hpp).

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

/// The triangles of `view` (the compacted `mesh`) that would fail the certificate; find_offending_triangles by
/// default, or that plus the pairs with the fixed triangles around a patch.
using offending_finder = std::function<std::vector<std::uint32_t>(const remesh_mesh& mesh, const surface_mesh& view)>;

class verified_stages {
 public:
  /// `max_triangles`: errc::limit_exceeded when a stage leaves more faces.
  verified_stages(const gaussian_field& field, const remesh_thresholds& thresholds, std::size_t max_triangles,
                  progress_token& progress, offending_finder finder = {});

  /// Runs `stage` on `state` in place. With `settle`, then settles the vertices (settle_vertices()) and checks the
  /// result with the certificate's tests (degenerate triangles, exact self-intersection, unsettled vertices):
  /// returns whether it passed (when not, last_failure() says where). Else true. errc::cancelled or
  /// errc::limit_exceeded leave `state` partly edited.
  result<bool> run(remesh_mesh& state, const remesh_stage& stage, bool settle);

  const operation_counts& counts() const { return counts_; }
  std::size_t field_evaluations() const { return field_evaluations_; }
  const check_failure& last_failure() const { return failure_; }

 private:
  const gaussian_field& field_;
  remesh_thresholds thresholds_;
  std::size_t max_triangles_;
  progress_token& progress_;
  offending_finder finder_;
  operation_counts counts_;
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
