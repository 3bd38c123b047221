#pragma once
/// @file edge_root.hpp
/// Surface points on lattice edges (paper §3 finds them on x-parallel lines; here every cut edge of the
/// tetrahedral lattice gets one): the root of φ = t0 between an inside and an outside end point, on the exact
/// (cut-off) field along the edge. The first guess interpolates ln φ through three lattice values on the edge's line;
/// each step solves the quadratic Taylor model of ln(φ/t0) (third order: about 2.4 field evaluations per root), kept
/// inside the bracket and safeguarded by bisection. Roots are exact to ~1e-15 of the edge; where φ crosses t0 more
/// than once on an edge, the root is one of the crossings.

#include <cstdint>
#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"

namespace tracemesh {

/// Fraction kept between a root and an edge's end points, so no two vertices of a tetrahedron coincide.
inline constexpr double edge_root_margin = 1e-4;

struct edge_vertex {
  std::uint64_t key;  ///< lattice edge key
  vec3 position;      ///< the root of φ = t0 on that edge
  vec3 normal;        ///< −∇φ/|∇φ| there (zero where ∇φ vanishes), from the same atoms the root was solved on
};

/// Roots on the cut edges owned by the block's cubes: each cube owns the seven edges leaving its lowest corner, so
/// every cut edge is solved exactly once. `atoms` and `values` as for sample_block / triangulate_block.
/// Appends to `out` in cube order.
void solve_block_roots(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                       std::span<const std::uint32_t> atoms, std::span<const double> values,
                       std::vector<edge_vertex>& out);

}  // namespace tracemesh
