#pragma once
/// @file line_roots.hpp
/// Surface points on lines parallel to x (TMSmesh stage one, paper §3 and eq. 6): the roots of φ(x, y, z) = t0 on
/// the 64 lines of a lattice block.
///
/// First, φ is bounded over four pieces of each line span from the same separable kernel (per atom, its factor's
/// extremes over a piece; the paper's eqs. 3–5 along a line): a span below t0, or above it, on every piece holds no
/// root and is skipped. Per remaining block line, the span x ∈ [8·i·h̃, 8·(i+1)·h̃) is cut into fits of
/// cells_per_fit cells; φ is sampled at the M + 1 Gauss–Legendre nodes of each fit and at both span ends from the
/// separable kernel (per atom: 8 + 8 + nodes exponentials for all 64 lines, instead of one per atom and point), and
/// the degree-M Legendre series of eq. 6 interpolating those samples is searched for roots of series = t0
/// (legendre.hpp: Bernstein subdivision).
///
/// The root count is then proved, interval by interval between consecutive samples (whose values are exact).
/// First by curvature: the per-atom bounds extended to φ_xx (|d²/dx² e^(d·δx²/r²)| = 2(−d/r²)·|2t − 1|·e^(−t),
/// t = −d·δx²/r², bounded over each piece) bound |φ''| ≤ K, so φ lies within K·w²/8 of the chord between an interval's
/// end values (no root when both ends are farther from t0, on one side) and φ' within K·w/2 of the chord's slope
/// (monotone: one root when the ends lie on opposite sides of t0, none otherwise). Where that does not decide, by the
/// bounds of φ and φ_x over the interval (the factor's slope 2d·δx/r²·e^(d·δx²/r²) has its extremes at
/// |δx| = r/√(−2d), so it is bounded over an interval exactly): one-sided, or monotone. An interval that neither
/// proves is halved (φ sampled at its middle) until its halves do, or until max_interval_splits halvings leave an
/// interval of a few 1e-7·h̃ around a tangency of the line with the surface, whose roots are then counted by the signs
/// at its ends (line_root_stats::tangent_intervals). Each one-root interval is solved by third-order steps on
/// ln(φ/t0) (the quadratic Taylor model from φ, φ_x, φ_xx: exact for a single atom) from the series' root inside it
/// (the Legendre fit stays the root finder; the bounds certify it), safeguarded by bisection within the interval; a
/// series root in an interval proved empty is rejected. A root is accepted when the last correction is at most
/// 1e-10 Å (root = last point + correction, φ_x from the last evaluation), which leaves |φ − t0| ≲ 1e-13·t0 for a
/// simple root; then kept if it lies in the block's half-open span. Roots of one line closer than 1e-9 Å with the
/// same sign of φ_x are one root.
///
/// The curvature and slope bounds are those of the smooth sum of the atoms that reach an interval; the cut-off field
/// differs from it by jumps below the cutoff tolerance (gaussian_field.hpp), so a monotone interval can hold more than
/// one root only where φ lies within such a jump of t0.
///
/// Deterministic: the result depends only on the inputs (the simd width, fixed per machine, only groups lane sums).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/field/gaussian_field.hpp"
#include "core/lattice/lattice.hpp"
#include "core/trace/legendre.hpp"

namespace tracemesh {

struct line_root {
  double x;      ///< Å, root of φ(x, y, z) = t0 on the line
  double phi_x;  ///< ∂φ/∂x at the root (its sign says on which side φ > t0, i.e. inside)
};

struct line_root_stats {
  std::size_t lines = 0;              ///< line spans searched
  /// line spans proven free of roots (and dips) by the bounds of φ over their pieces, and neither sampled nor fitted
  std::size_t proven_lines = 0;
  /// φ values computed (quadrature nodes and span ends of the lines sampled, Newton steps), one per point
  std::size_t field_evaluations = 0;
  std::size_t polynomial_roots = 0;   ///< roots solved from a root of the Legendre series inside their interval
  std::size_t rejected_roots = 0;     ///< series roots in intervals proved empty, or not confirmed by polishing
  std::size_t bracketed_roots = 0;    ///< roots of one-root intervals where the series had none
  std::size_t split_intervals = 0;    ///< intervals halved because neither bound proved them
  /// intervals still unproved after max_interval_splits halvings (a tangency): roots counted by their ends' signs
  std::size_t tangent_intervals = 0;
  std::size_t quiet_fits = 0;         ///< fits dismissed without a root search (Bernstein hull on one side of t0)
  std::size_t fits = 0;               ///< fits computed
};

/// Lattice cells per Legendre fit along x: the paper's 4 Å cubes at h̃ = 1 Å.
inline constexpr int cells_per_fit = 4;
/// Fits per block line.
inline constexpr int fits_per_line = lattice::block_cells / cells_per_fit;
/// Lines per block: (j, k) ∈ 0..7², line index j + 8k.
inline constexpr int lines_per_block = lattice::block_cells * lattice::block_cells;

/// Roots of each line owned by `block` of `lat` (spacing h̃ = lat.spacing()): the 64 lines y = (8·block.j + j)·h̃,
/// z = (8·block.k + k)·h̃, j, k ∈ 0..7, over x ∈ [8·block.i·h̃, 8·(block.i+1)·h̃) (a root exactly on the upper end
/// belongs to the next block). Coordinates are computed as lat.point() does, so neighbouring blocks agree on ends.
struct block_line_roots {
  std::array<std::uint32_t, 65> first{};  ///< roots of line (j, k) are roots[first[j + 8k] .. first[j + 8k + 1])
  std::vector<line_root> roots;           ///< per line sorted by x
  /// Dips (line_root_settings::dip_ratio): by line, then x.
  struct dip {
    int line;  ///< j + 8k
    double x;  ///< Å, the node where φ is lowest
  };
  std::vector<dip> dips;
};

/// Halvings of an interval whose root count the bounds cannot prove (line_roots.hpp), at most: from a node gap of
/// about h̃/3 down to a few 1e-7·h̃.
inline constexpr int max_interval_splits = 20;

/// Tunables of line_root_finder.
struct line_root_settings {
  int degree = 10;          ///< M, degree of the Legendre series (paper: 10); 1..legendre_max_degree
  /// Dips: a node sample (not a span end) where φ is lower than at both neighbouring samples and lies in
  /// (t0, dip_ratio·t0]. The line passes near a pocket of φ < t0 that may touch no line (a cavity between lines,
  /// untouched_cavities.hpp). 0: none reported.
  double dip_ratio = 0;
  /// Bound φ over each line span first (per atom, its factor's extremes over each piece of the span; the paper's
  /// eqs. 3–5 along a line) and skip the spans that lie wholly on one side of t0: they hold no root, and the roots
  /// of the others are the same bits either way. Off: every span is sampled and fitted.
  bool prove_root_free = true;
};

/// Roots of φ = t0 on the lines of a block: tables for one degree and scratch reused from block to block (no
/// allocation once warm; building one costs a few µs). Not thread-safe: use one finder per thread. Results never
/// depend on what the finder computed before.
class line_root_finder {
 public:
  /// std::invalid_argument when settings.degree is outside 1..legendre_max_degree.
  explicit line_root_finder(const line_root_settings& settings = {});

  /// The roots on each line owned by `block` (see block_line_roots), from the Legendre series of each fit of
  /// cells_per_fit cells (eq. 6), polished on the exact cut-off φ (the same cutoff as gaussian_field: atom k
  /// contributes where |p − c_k|² < cutoff2_k). `atoms`: distinct field-internal indices of (at least) every atom
  /// whose cutoff sphere may reach the block, e.g. from field.atoms_near_box(lat.block_box(block), atoms); extra
  /// atoms cost time only; their order is the summation order (atoms_near_box's ascending order makes the bits
  /// independent of the caller). `out` is overwritten; `stats` is added to.
  void find(const gaussian_field& field, const lattice& lat, const lattice_index& block,
            std::span<const std::uint32_t> atoms, block_line_roots& out, line_root_stats& stats);

  /// What the bounds prove about an interval of a line.
  enum class interval_proof : char { no_root, one_root, undecided };

  /// An interval of a line proved to hold exactly one root: (lo, hi), and whether φ ≥ t0 at lo.
  struct root_bracket {
    double lo, hi;
    bool lo_inside;
  };

  /// Scratch of one block (sizes grow to the largest block seen). Public so that the kernels in line_roots.cpp
  /// can take it; not part of the interface.
  struct workspace {
    std::vector<double> node_x;                    ///< x of a line's samples (span ends and nodes), padded
    std::vector<double> node_factor, node_dx2;     ///< one atom's x factors and δx² at the nodes
    std::vector<double> x, y, z, inv_r2, cutoff2;  ///< the block's atoms, padded
    std::vector<double> ey, dy2, ez, dz2;          ///< per line y (z) and atom: 1-D factor and squared offset
    std::vector<double> sums;                      ///< φ at the nodes, per line
    /// One atom's factors on the 8 y and 8 z lines of the block, and the rectangle of lines its cutoff reaches.
    struct atom_factors {
      alignas(64) std::array<double, simd::max_lanes> ey, dy2, ez, dz2;
      /// Per piece of the span (line_roots.cpp): the bound on |d²/dx²| of the x factor over it, and δx² to its
      /// nearest point
      alignas(32) std::array<double, 4> piece_curvature, piece_near2;
      int j_lo, j_hi, k_lo, k_hi;  ///< the lines with δy² < cutoff² (δz² < cutoff²): [j_lo, j_hi) × [k_lo, k_hi)
      bool reaches_a_line() const { return j_lo < j_hi && k_lo < k_hi; }
    };
    std::vector<atom_factors> factors;             ///< per atom
    std::vector<double> bounds;                    ///< per line: upper, then lower bounds of φ on its pieces
    std::array<char, lines_per_block> sampled{};   ///< per line: 1 when its nodes are sampled
    std::vector<double> line_x, line_d_inv_r2, line_weight, line_dy2, line_dz2, line_cutoff2;  ///< one line's atoms
    std::size_t line_count = 0;                           ///< atoms in the line arrays
    std::vector<line_root> accepted;                      ///< roots of the current line
    std::vector<double> candidates;                       ///< candidates of the current line, Å
    std::vector<double> legendre, bernstein;              ///< one fit's coefficients
    std::vector<double> curvature;           ///< per line and piece: a bound on |φ_xx| (bound_lines)
    std::vector<interval_proof> proofs;      ///< the current line's intervals, as the curvature bound proves them
    std::vector<double> interval_curvature;  ///< and the bound on |φ_xx| over each
    std::vector<root_bracket> brackets;   ///< the current line's one-root intervals
  };

 private:
  line_root_settings settings_;
  legendre_fitter fitter_;
  std::vector<double> values_to_bernstein_;  ///< (M+1)²: Bernstein coefficients of the fit from the node values
  workspace scratch_;
};

}  // namespace tracemesh
