#pragma once
/// @file band_culling.hpp
/// Stage one of TMSmesh (paper eqs. 3–5): bound φ from below and above on axis-aligned cubes and drop cubes whose
/// bounds exclude t0. Cubes are refined as an octree from coarse cubes around the atoms down to lattice blocks.

#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"

namespace tracemesh {

struct field_bounds {
  double lower = 0;  ///< φ ≥ lower everywhere in the box
  double upper = 0;  ///< φ ≤ upper everywhere in the box
};

/// Bounds of the cut-off field on `box`, summing over `atoms` (field-internal indices; must include every atom
/// whose cutoff sphere reaches the box). Per atom and axis, the 1-D kernel's extreme values on the box's span are
/// at the faces, or 1 when the centre's coordinate lies inside the span (eq. 4); products give the 3-D bounds (eq. 5).
/// An atom adds to `lower` only when its cutoff sphere contains the whole box, since the cut-off kernel is 0 beyond.
field_bounds bound_field_on_box(const gaussian_field& field, const box3& box, std::span<const std::uint32_t> atoms);

/// True when the bounds prove that the box holds no point of {φ = t0}; keeps a relative margin of 1e-9 so that
/// rounding in sampling can never put a sign change into a dropped block.
bool bounds_exclude(const field_bounds& bounds, double t0);

/// The lattice blocks that may hold surface, sorted by (i, j, k). errc::cancelled when the token asks to stop.
result<std::vector<lattice_index>> cull_blocks(const gaussian_field& field, const lattice& lat, progress_token& progress);

}  // namespace tracemesh
