#pragma once
/// @file lattice_sampler.hpp
/// φ at the lattice points of one block, from the separable kernel (paper §1: exp(d|x−c|²/r²) is a product of
/// three 1-D factors), so each atom costs 3·(n+1) exponentials instead of (n+1)³. Factors and lattice rows are
/// computed several lanes at a time (simd::dispatch); every point gets the same roundings in every lane and block.

#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"

namespace tracemesh {

inline constexpr int block_points = lattice::block_cells + 1;  ///< lattice points per block edge

/// Fills `values` with φ at the block_points³ points of `block` (index (x + y·n + z·n²), x fastest).
/// `atoms`: field-internal indices of the atoms whose cutoff reaches the block, ascending. A point's value sums
/// exactly the atoms within cutoff of that point, in ascending order: the value of a lattice point is bitwise the
/// same whichever block computes it, so neighbouring blocks agree on every sign.
void sample_block(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                  std::span<const std::uint32_t> atoms, std::vector<double>& values);

}  // namespace tracemesh
