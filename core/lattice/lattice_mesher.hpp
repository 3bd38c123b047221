#pragma once
/// @file lattice_mesher.hpp
/// The lattice path after culling: φ sampled on the lattice points of the surviving blocks, a root of φ = t0 on
/// every cut edge of the tetrahedral lattice, and the marching-tetrahedra polygons on them, split into triangles.

#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"
#include "core/limits.hpp"
#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/stage_clock.hpp"
#include "core/status.hpp"

namespace tracemesh {

/// The closed, manifold, oriented marching-tetrahedra mesh of the culled `blocks` (sorted by (i, j, k)), with the
/// root solver's normals; atom_index left empty. Finishes the stages sampling, roots and triangulating on `clock`.
/// Errors: limit_exceeded (lattice points or triangles over `limits`), nothing_to_mesh (no cut edge), cancelled,
/// internal_error (a cut edge without a root).
result<surface_mesh> mesh_lattice_blocks(const gaussian_field& field, const lattice& lat,
                                         const std::vector<lattice_index>& blocks, const mesh_limits& limits,
                                         progress_token& progress, stage_clock& clock);

}  // namespace tracemesh
