#pragma once
/// @file trace_mesher.hpp
/// The trace path after culling (TMSmesh stage two): roots of φ = t0 on lines parallel to x through the lattice
/// points of the surviving blocks (eq. 6, line_roots.hpp), contours traced between neighbouring lines in xy and xz
/// planes (Algorithm 1, trace_step.hpp), closed polygons around each cell of four lines (Algorithm 2) and their
/// triangulation (loop_triangulation.hpp).

#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"
#include "core/limits.hpp"
#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/stage_clock.hpp"
#include "core/status.hpp"
#include "core/trace/trace_parameters.hpp"

namespace tracemesh {

/// h̃ (Å) for `density` vertices per Å² (calibrated: see trace_mesher.cpp).
double trace_line_spacing(double density);

/// The triangulated polygons of the culled `blocks` (sorted by (i, j, k)) of `lat`, whose spacing is h̃: closed,
/// manifold, outward oriented, with the field normals at the vertices; atom_index left empty. Finishes the stages
/// roots, tracing and triangulating on `clock` and fills `stats`. Errors: limit_exceeded, nothing_to_mesh,
/// cancelled, internal_error (a polygon that could not be closed or triangulated even by the counted fallback).
/// `walk_field`: the same surface's field with a looser cutoff, on which the traces walk between lines.
/// `delivered_as_is` (refine=none): edges at an arc point under h̃/2 are collapsed too, but in untouched cavities
/// (trace_mesher.cpp, raw_collapse_below; stats.collapsed_raw_edges), while stats.raw_vertices and raw_triangles
/// count the polygons' own.
result<surface_mesh> mesh_trace_blocks(const gaussian_field& field, const gaussian_field& walk_field,
                                       const lattice& lat,
                                       const std::vector<lattice_index>& blocks, const trace_parameters& params,
                                       bool delivered_as_is, const mesh_limits& limits, progress_token& progress,
                                       stage_clock& clock, trace_stats& stats);

}  // namespace tracemesh
