#include "core/trace/line_roots.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/field/separable_kernel.hpp"

namespace tracemesh {
namespace {

/// A root is accepted when the last correction of its polishing is at most this (Å).
constexpr double root_tolerance = 1e-10;
/// Roots of one line closer than this (Å) with the same sign of φ_x are the same root.
constexpr double duplicate_distance = 1e-9;
/// Bracketed polishing gives up after this many steps (bisection alone needs ~40 on a fit).
constexpr int max_bracket_iterations = 100;
/// Roots and extrema of a fit's series are polished to this (in s): they only start polishing on φ itself, from
/// which the series differs by its fit error (≳ 1e-8 of the span).
constexpr double series_root_tolerance = 1e-9;
/// Lines per block edge.
constexpr int block_lines = lattice::block_cells;
/// Pieces of a block line bounded separately (bound_lines): two cells each, an upper and a lower bound per piece
/// filling one vector of simd::max_lanes.
constexpr int bound_pieces = simd::max_lanes / 2;
static_assert(lattice::block_cells % bound_pieces == 0);
static_assert(std::tuple_size_v<decltype(line_root_finder::workspace::atom_factors::piece_curvature)> == bound_pieces);
/// Relative margin between a bound and t0 for it to prove a line one-sided: far above the rounding of sums of a few
/// hundred terms (~1e-13), far below any distance at which a root could be.
constexpr double bound_margin = 1e-9;

/// Node groups of a line at most: fits_per_line·(legendre_max_degree + 1) + 2 samples padded to max_lanes, in groups of
/// 2 lanes.
constexpr int max_node_groups =
    (fits_per_line * (legendre_max_degree + 1) + 2 + simd::max_lanes - 1) / simd::max_lanes * simd::max_lanes / 2;

std::size_t padded_size(std::size_t n) { return (n + simd::max_lanes - 1) / simd::max_lanes * simd::max_lanes; }

/// φ, dφ/dx and d²φ/dx² at one point of a line.
struct line_sample {
  double value, slope, curvature;
};

/// The step to the root of the quadratic Taylor model of L(x) = ln(φ/t0) (L' = φ'/φ, L'' = φ''/φ − L'²): the
/// root nearest to x, or the Newton step on L where the model has no real root. Exact for one atom (L is a
/// parabola in x). NaN where φ ≤ 0 (no atom within cutoff) or φ' = 0.
double log_step(const line_sample& s, double t0) {
  if (!(s.value > 0) || s.slope == 0) return std::numeric_limits<double>::quiet_NaN();
  const double l0 = std::log(s.value / t0), l1 = s.slope / s.value, l2 = s.curvature / s.value - l1 * l1;
  const double discriminant = l1 * l1 - 2 * l0 * l2;
  if (discriminant >= 0) return -2 * l0 / (l1 + std::copysign(std::sqrt(discriminant), l1));
  return -l0 / l1;
}

/// The lines' y (or z) coordinates, as lat.point() computes them, padded to a whole vector.
std::array<double, simd::max_lanes> line_coordinates(std::int64_t block_index, double h) {
  std::array<double, simd::max_lanes> c{};
  for (int n = 0; n < block_lines; ++n) {
    c[static_cast<std::size_t>(n)] = static_cast<double>(block_index * block_lines + n) * h;
  }
  return c;
}

/// The index range [lo, hi) of the entries of `values` (count of them) below `limit` — one range, as the values
/// are squared distances from one point to points sorted along an axis, so the entries below any limit are
/// contiguous. Branch-free (conditional moves): the ranges vary from atom to atom.
[[gnu::always_inline]] inline void range_below(const double* values, int count, double limit, int& lo, int& hi) {
  lo = count;
  hi = 0;
  for (int n = 0; n < count; ++n) {
    const bool below = values[n] < limit;
    lo = below && n < lo ? n : lo;
    hi = below ? n + 1 : hi;
  }
}

using atom_line_factors = line_root_finder::workspace::atom_factors;

/// Each atom's y and z factors and squared offsets per line (ws.factors[a], and by line ws.ey[j·stride + a], …, for
/// the lines' atom lists), for the bounds and the node samples: per atom, 8 y and 8 z exponentials.
template <int W>
[[gnu::always_inline]] inline void line_factors(const gaussian_field& field, line_root_finder::workspace& ws,
                                                std::size_t count, std::size_t stride,
                                                const std::array<double, simd::max_lanes>& line_y,
                                                const std::array<double, simd::max_lanes>& line_z) {
  const double d = field.d();
  if (ws.factors.size() < count) ws.factors.resize(count);
  for (std::size_t a = 0; a < count; ++a) {
    atom_line_factors& f = ws.factors[a];
    simd::axis_factors<W>(line_y.data(), simd::max_lanes, ws.y[a], d, ws.inv_r2[a], f.dy2.data(), f.ey.data());
    simd::axis_factors<W>(line_z.data(), simd::max_lanes, ws.z[a], d, ws.inv_r2[a], f.dz2.data(), f.ez.data());
    range_below(f.dy2.data(), block_lines, ws.cutoff2[a], f.j_lo, f.j_hi);
    range_below(f.dz2.data(), block_lines, ws.cutoff2[a], f.k_lo, f.k_hi);
    for (int n = 0; n < block_lines; ++n) {
      const auto nn = static_cast<std::size_t>(n);
      ws.ey[nn * stride + a] = f.ey[nn];
      ws.dy2[nn * stride + a] = f.dy2[nn];
      ws.ez[nn * stride + a] = f.ez[nn];
      ws.dz2[nn * stride + a] = f.dz2[nn];
    }
  }
}

/// Bounds of φ over each piece of each line of the block (the paper's eqs. 3–5 on a line: the y and z factors of an
/// atom are constants of the line, and its x factor e^(d·δx²/r²) is monotone in |δx|, so over a piece it lies
/// between its values at the piece's nearest and farthest points from the centre). Per line, lanes 0..3 of
/// ws.bounds hold upper bounds on the four pieces, lanes 4..7 lower bounds. An atom adds to an upper bound where its
/// cutoff reaches some point of the piece (near δx² + ρ² < cutoff²), to a lower bound where it covers the whole
/// piece (far δx² + ρ² < cutoff²), so the bounds hold for the cut-off field itself.
template <int W>
[[gnu::always_inline]] inline void bound_lines(const gaussian_field& field, line_root_finder::workspace& ws,
                                               std::size_t count, const std::array<double, bound_pieces + 1>& edges) {
  using F = typename simd::pack<W>::f64;
  const double d = field.d();
  const double scale = kernel_exp(-d);
  ws.bounds.assign(static_cast<std::size_t>(lines_per_block) * simd::max_lanes, 0.0);
  ws.curvature.assign(static_cast<std::size_t>(lines_per_block) * bound_pieces, 0.0);
  const double peak_curvature = 2 * kernel_exp(-1.5);  // the maximum of |2t − 1|·e^(−t) for t > 1/2, at t = 3/2
  alignas(64) std::array<double, simd::max_lanes> offset2{}, factor{};
  for (std::size_t a = 0; a < count; ++a) {
    atom_line_factors& f = ws.factors[a];
    if (!f.reaches_a_line()) continue;
    const double c = ws.x[a], cutoff2 = ws.cutoff2[a];
    for (int p = 0; p < bound_pieces; ++p) {
      const double lo = edges[static_cast<std::size_t>(p)] - c, hi = edges[static_cast<std::size_t>(p + 1)] - c;
      const double nearest = lo > 0 ? lo : hi < 0 ? -hi : 0.0;
      offset2[static_cast<std::size_t>(p)] = nearest * nearest;
      offset2[static_cast<std::size_t>(bound_pieces + p)] = std::max(lo * lo, hi * hi);
    }
    for (int m = 0; m < simd::max_lanes; m += W) {
      F e;
      simd::load(e, offset2.data() + m);
      e *= d * ws.inv_r2[a];
      simd::exp_in_place(e);
      simd::store(factor.data() + m, e);
    }
    // |d²/dx² e^(−t)| = 2·rate·|2t − 1|·e^(−t) with t = rate·δx², rate = −d/r²: its maximum over each piece
    // (added to the lines' curvature bounds by sample_nodes, for the lines sampled).
    const double rate = -d * ws.inv_r2[a];
    for (int p = 0; p < bound_pieces; ++p) {
      f.piece_near2[static_cast<std::size_t>(p)] = offset2[static_cast<std::size_t>(p)];
      const double t_near = rate * offset2[static_cast<std::size_t>(p)];
      const double t_far = rate * offset2[static_cast<std::size_t>(bound_pieces + p)];
      double q = std::max(std::abs(2 * t_near - 1) * factor[static_cast<std::size_t>(p)],
                          std::abs(2 * t_far - 1) * factor[static_cast<std::size_t>(bound_pieces + p)]);
      if (t_near <= 1.5 && t_far >= 1.5) q = std::max(q, peak_curvature);
      f.piece_curvature[static_cast<std::size_t>(p)] = 2 * rate * q;
    }
    for (int k = f.k_lo; k < f.k_hi; ++k) {
      for (int j = f.j_lo; j < f.j_hi; ++j) {
        const double rho2 = f.dy2[static_cast<std::size_t>(j)] + f.dz2[static_cast<std::size_t>(k)];
        const double weight = scale * f.ey[static_cast<std::size_t>(j)] * f.ez[static_cast<std::size_t>(k)];
        double* row = ws.bounds.data() + static_cast<std::size_t>(j + block_lines * k) * simd::max_lanes;
        simd::add_kernel_terms<W>(row, factor.data(), offset2.data(), weight, rho2, cutoff2, 0, simd::max_lanes);
      }
    }
  }
}

/// Whether each line's bounds prove it free of roots and dips (ws.sampled[line] = 0) or not (1): φ below t0 on
/// every piece, or above `inside_level` (t0, or the dips' ceiling when dips are asked for) on every piece. The
/// bounds and the samples are sums of the same terms, rounded differently; `bound_margin` keeps the proof clear of
/// that rounding. Returns the lines to sample.
int choose_sampled_lines(line_root_finder::workspace& ws, double t0, double inside_level) {
  int sampled = 0;
  for (int line = 0; line < lines_per_block; ++line) {
    const double* b = ws.bounds.data() + static_cast<std::size_t>(line) * simd::max_lanes;
    bool outside = true, inside = true;
    for (int p = 0; p < bound_pieces; ++p) {
      outside = outside && b[p] < t0 * (1 - bound_margin);
      inside = inside && b[bound_pieces + p] > inside_level * (1 + bound_margin);
    }
    ws.sampled[static_cast<std::size_t>(line)] = !(outside || inside);
    sampled += ws.sampled[static_cast<std::size_t>(line)];
  }
  return sampled;
}

/// φ at every quadrature node of the lines to sample (ws.sums[line·P + m], ws.sampled) from the separable kernel:
/// per atom its y and z factors (line_factors) and one x factor per node; an atom adds to the nodes of a line within
/// its cutoff (δx² + ρ² < cutoff², ρ² = δy² + δz²). Also the lines' curvature bounds per piece (ws.curvature), from
/// the atoms' piece bounds (bound_lines).
///
/// The loops have no data-dependent branch inside an atom (mispredicted branches cost more than the arithmetic they
/// skip): each atom works on the rectangle of lines j ∈ [j_lo, j_hi), k ∈ [k_lo, k_hi) with δy² < cutoff² and
/// δz² < cutoff², and on the node groups (W nodes) that some node of some line reaches, every node masked by its
/// exact cutoff test. Masked terms add +0, which leaves the sums' bits unchanged: every node gets exactly the sum
/// over the atoms within its cutoff, in atom order.
template <int W>
[[gnu::always_inline]] inline void sample_nodes(const gaussian_field& field, line_root_finder::workspace& ws,
                                                std::size_t count, int node_stride) {
  using F = typename simd::pack<W>::f64;
  const double d = field.d();
  const double scale = kernel_exp(-d);  // e^(−d): the "− 1" of eq. 2
  std::array<double, max_node_groups> group_min{};
  double* const ex = ws.node_factor.data();
  double* const dx2 = ws.node_dx2.data();
  const int groups = node_stride / W;
  for (std::size_t a = 0; a < count; ++a) {
    const double inv_r2 = ws.inv_r2[a], cutoff2 = ws.cutoff2[a];
    const atom_line_factors& f = ws.factors[a];
    if (!f.reaches_a_line()) continue;
    const auto& ey = f.ey;
    const auto& dy2 = f.dy2;
    const auto& ez = f.ez;
    const auto& dz2 = f.dz2;
    const int j_lo = f.j_lo, j_hi = f.j_hi, k_lo = f.k_lo, k_hi = f.k_hi;
    const double nearest_rho2 = *std::min_element(dy2.begin(), dy2.begin() + block_lines) +
                                *std::min_element(dz2.begin(), dz2.begin() + block_lines);
    for (int m = 0; m < node_stride; m += W) {
      F delta;
      simd::load(delta, ws.node_x.data() + m);
      delta -= ws.x[a];
      simd::store(dx2 + m, delta * delta);
    }
    for (int g = 0; g < groups; ++g) {
      group_min[static_cast<std::size_t>(g)] = *std::min_element(dx2 + g * W, dx2 + (g + 1) * W) + nearest_rho2;
    }
    int g_lo, g_hi;
    range_below(group_min.data(), groups, cutoff2, g_lo, g_hi);
    // An atom that reaches no node may still reach a piece between nodes: it adds to the curvature bounds only.
    const bool reaches_a_node = g_lo < g_hi;
    if (reaches_a_node) {
      simd::axis_factors<W>(ws.node_x.data() + g_lo * W, (g_hi - g_lo) * W, ws.x[a], d, inv_r2, dx2 + g_lo * W,
                            ex + g_lo * W);
    }
    for (int k = k_lo; k < k_hi; ++k) {
      for (int j = j_lo; j < j_hi; ++j) {
        if (!ws.sampled[static_cast<std::size_t>(j + block_lines * k)]) continue;
        const double rho2 = dy2[static_cast<std::size_t>(j)] + dz2[static_cast<std::size_t>(k)];
        const double weight = scale * ey[static_cast<std::size_t>(j)] * ez[static_cast<std::size_t>(k)];
        double* row =
            ws.sums.data() + static_cast<std::size_t>(j + block_lines * k) * static_cast<std::size_t>(node_stride);
        if (reaches_a_node) simd::add_kernel_terms<W>(row, ex, dx2, weight, rho2, cutoff2, g_lo * W, g_hi * W);
        simd::add_kernel_terms<(W < bound_pieces ? W : bound_pieces)>(
            ws.curvature.data() + static_cast<std::size_t>(j + block_lines * k) * bound_pieces,
            f.piece_curvature.data(), f.piece_near2.data(), weight, rho2, cutoff2, 0, bound_pieces);
      }
    }
  }
}

/// The atoms of line (j, k) within their cutoff of it (ρ² < cutoff²), as columns for evaluate_line, padded with
/// entries that never contribute.
template <int W>
[[gnu::always_inline]] inline void gather_line_atoms(line_root_finder::workspace& ws, std::size_t count,
                                                     std::size_t stride, int j, int k, double d) {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  const double scale = kernel_exp(-d);
  const double* ey = ws.ey.data() + static_cast<std::size_t>(j) * stride;
  const double* dy2 = ws.dy2.data() + static_cast<std::size_t>(j) * stride;
  const double* ez = ws.ez.data() + static_cast<std::size_t>(k) * stride;
  const double* dz2 = ws.dz2.data() + static_cast<std::size_t>(k) * stride;
  std::size_t kept = 0;
  for (std::size_t a = 0; a < count; a += W) {
    F y2, z2, cutoff2;
    simd::load(y2, dy2 + a);
    simd::load(z2, dz2 + a);
    simd::load(cutoff2, ws.cutoff2.data() + a);
    M near = y2 + z2 < cutoff2;
    simd::clear_lanes_from(near, static_cast<std::int64_t>(a), static_cast<std::int64_t>(count));
    if (!simd::any_lane(near)) continue;
    for (int lane = 0; lane < W; ++lane) {
      if (!near[lane]) continue;
      const std::size_t n = a + static_cast<std::size_t>(lane);
      ws.line_x[kept] = ws.x[n];
      ws.line_d_inv_r2[kept] = d * ws.inv_r2[n];
      ws.line_weight[kept] = scale * ey[n] * ez[n];
      ws.line_dy2[kept] = dy2[n];
      ws.line_dz2[kept] = dz2[n];
      ws.line_cutoff2[kept] = ws.cutoff2[n];
      ++kept;
    }
  }
  for (std::size_t n = kept; n < padded_size(kept); ++n) {
    ws.line_x[n] = ws.line_d_inv_r2[n] = ws.line_weight[n] = ws.line_dy2[n] = ws.line_dz2[n] = 0;
    ws.line_cutoff2[n] = 0;  // never contributes
  }
  ws.line_count = kept;
}

/// W gathered atoms of the current line (gather_line_atoms), from entry `a` on.
template <class F>
struct line_atom_pack {
  F x, d_inv_r2, weight, dy2, dz2, cutoff2;
};
template <class F>
[[gnu::always_inline]] inline void load_line_atoms(const line_root_finder::workspace& ws, std::size_t a,
                                                   line_atom_pack<F>& p) {
  simd::load(p.x, ws.line_x.data() + a);
  simd::load(p.d_inv_r2, ws.line_d_inv_r2.data() + a);
  simd::load(p.weight, ws.line_weight.data() + a);
  simd::load(p.dy2, ws.line_dy2.data() + a);
  simd::load(p.dz2, ws.line_dz2.data() + a);
  simd::load(p.cutoff2, ws.line_cutoff2.data() + a);
}

/// φ, φ_x, φ_xx at x on the current line: each atom cut off exactly as gaussian_field does,
/// (δx² + δy²) + δz² < cutoff², and kernel = e^(−d)·e^(dδy²/r²)·e^(dδz²/r²)·e^(dδx²/r²).
template <int W>
[[gnu::always_inline]] inline line_sample evaluate_line(const line_root_finder::workspace& ws, double x) {
  using F = typename simd::pack<W>::f64;
  F value{}, slope{}, curvature{};
  for (std::size_t a = 0; a < ws.line_count; a += W) {
    line_atom_pack<F> atoms;
    load_line_atoms(ws, a, atoms);
    const F &d_inv_r2 = atoms.d_inv_r2, &weight = atoms.weight, &y2 = atoms.dy2, &z2 = atoms.dz2;
    const F& cutoff2 = atoms.cutoff2;
    const F dx = x - atoms.x;
    const F dx2 = dx * dx;
    const F r2 = (dx2 + y2) + z2;
    F kernel = d_inv_r2 * dx2;
    simd::exp_in_place(kernel);
    kernel *= weight;
    simd::keep_lanes(kernel, r2 < cutoff2);
    const F g = 2 * d_inv_r2 * dx;
    value += kernel;
    slope += g * kernel;
    curvature += (2 * d_inv_r2 + g * g) * kernel;
  }
  return {simd::lane_sum(value), simd::lane_sum(slope), simd::lane_sum(curvature)};
}

/// The root in (lo, hi) where φ − t0 is inside (≥ 0) near lo iff `lo_inside`, and the opposite near hi, from `x`
/// inside it: third-order steps on ln(φ/t0) kept inside the shrinking bracket, bisection where a step would leave it.
template <int W>
[[gnu::always_inline]] inline bool polish_bracket(const line_root_finder::workspace& ws, double t0, double lo,
                                                  bool lo_inside, double hi, double x, line_root& root,
                                                  std::size_t& evaluations) {
  for (int iteration = 0; iteration < max_bracket_iterations; ++iteration) {
    const line_sample s = evaluate_line<W>(ws, x);
    ++evaluations;
    ((s.value >= t0) == lo_inside ? lo : hi) = x;
    const double step = log_step(s, t0);
    if (std::abs(step) <= root_tolerance || hi - lo <= root_tolerance) {
      root = {std::abs(step) <= root_tolerance ? x + step : x, s.slope};
      return true;
    }
    double next = x + step;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    x = next;
  }
  return false;
}

/// Sorts roots by x and merges those closer than duplicate_distance with the same sign of φ_x.
void sort_unique(std::vector<line_root>& roots) {
  std::sort(roots.begin(), roots.end(),
            [](const line_root& a, const line_root& b) { return a.x < b.x || (a.x == b.x && a.phi_x < b.phi_x); });
  const auto end = std::unique(roots.begin(), roots.end(), [](const line_root& a, const line_root& b) {
    return b.x - a.x <= duplicate_distance && (a.phi_x >= 0) == (b.phi_x >= 0);
  });
  roots.erase(end, roots.end());
}

/// Everything about one block that the per-line work needs.
struct block_geometry {
  double x_lo, x_hi;                           ///< the block's span, Å (half-open)
  std::array<double, fits_per_line> fit_mid;   ///< centre of each fit, Å
  std::array<double, fits_per_line> fit_half;  ///< half width of each fit, Å
};

block_geometry make_geometry(const lattice& lat, const lattice_index& block) {
  const double h = lat.spacing();
  block_geometry g{};
  const std::int64_t first = block.i * lattice::block_cells;
  g.x_lo = static_cast<double>(first) * h;
  g.x_hi = static_cast<double>(first + lattice::block_cells) * h;
  for (int q = 0; q < fits_per_line; ++q) {
    const double lo = static_cast<double>(first + q * cells_per_fit) * h;
    const double hi = static_cast<double>(first + (q + 1) * cells_per_fit) * h;
    g.fit_mid[static_cast<std::size_t>(q)] = 0.5 * (lo + hi);
    g.fit_half[static_cast<std::size_t>(q)] = 0.5 * (hi - lo);
  }
  return g;
}

/// Makes `column` hold at least `size` entries.
void grow_to(std::vector<double>& column, std::size_t size) {
  if (column.size() < size) column.resize(size);
}

/// Sizes the workspace for `count` atoms and `node_stride` nodes per line and copies the atoms into it.
void prepare_workspace(const gaussian_field& field, std::span<const std::uint32_t> atoms, std::size_t node_stride,
                       line_root_finder::workspace& ws) {
  const std::size_t count = atoms.size(), stride = padded_size(count);
  // Columns only grow (a vector that grows back value-initialises, i.e. clears, what it regains), and are not
  // cleared: every entry read is written first, except the padding of the atom columns, which vector loads read and
  // which is set here (cutoff2 = 0: never contributes).
  for (auto* column : {&ws.x, &ws.y, &ws.z, &ws.inv_r2, &ws.cutoff2}) {
    grow_to(*column, stride);
    std::fill(column->begin() + static_cast<std::ptrdiff_t>(count),
              column->begin() + static_cast<std::ptrdiff_t>(stride), 0.0);
  }
  const gaussian_field::atom_arrays all = field.atoms();
  for (std::size_t n = 0; n < count; ++n) {
    const std::uint32_t k = atoms[n];
    ws.x[n] = all.x[k];
    ws.y[n] = all.y[k];
    ws.z[n] = all.z[k];
    ws.inv_r2[n] = all.inv_r2[k];
    ws.cutoff2[n] = all.cutoff2[k];
  }
  for (auto* column : {&ws.ey, &ws.dy2, &ws.ez, &ws.dz2}) grow_to(*column, stride * block_lines);
  grow_to(ws.node_factor, node_stride);
  grow_to(ws.node_dx2, node_stride);
  for (auto* column : {&ws.line_x, &ws.line_d_inv_r2, &ws.line_weight, &ws.line_dy2, &ws.line_dz2, &ws.line_cutoff2}) {
    grow_to(*column, stride);
  }
  ws.sums.assign(static_cast<std::size_t>(lines_per_block) * node_stride, 0.0);
}

/// What a line's fits need besides the node values.
struct fit_context {
  const legendre_fitter& fitter;
  std::span<const double> values_to_bernstein;  ///< (M+1)² matrix
  const block_geometry& geometry;
  double t0;
};

/// out[r] = Σₘ matrix[m·rows + r]·f[m], r < rows, m < columns (a column-major matrix–vector product; the inner
/// loop runs over contiguous entries, which the compiler vectorises).
void multiply_columns(const double* matrix, int rows, int columns, const double* f, double* out) {
  std::fill(out, out + rows, 0.0);
  for (int m = 0; m < columns; ++m) {
    const double* column = matrix + static_cast<std::ptrdiff_t>(m) * rows;
    const double value = f[m];
    for (int r = 0; r < rows; ++r) out[r] += column[r] * value;
  }
}

/// The roots of one fit's series (Å, appended to `candidates`) from its node values `f` (M + 1 of them). A fit whose
/// Bernstein coefficients all lie on one side of t0 has none (it is quiet).
void fit_candidates(const fit_context& c, int fit, const double* f, std::vector<double>& a, std::vector<double>& b,
                    std::vector<double>& candidates, line_root_stats& stats) {
  const int points = c.fitter.points();
  ++stats.fits;
  multiply_columns(c.values_to_bernstein.data(), points, points, f, b.data());
  bool changes = false;
  for (int j = 0; j < points; ++j) {
    b[static_cast<std::size_t>(j)] -= c.t0;  // the Bernstein coefficients of t0 are all t0
    if (j > 0) changes |= (b[static_cast<std::size_t>(j)] >= 0) != (b[static_cast<std::size_t>(j - 1)] >= 0);
  }
  if (!changes) {
    ++stats.quiet_fits;
    return;
  }
  c.fitter.coefficients(std::span<const double>(f, static_cast<std::size_t>(points)), a);  // eq. 6
  a[0] -= c.t0;
  const std::size_t before = candidates.size();
  legendre_roots(a, std::span<const double>(b.data(), static_cast<std::size_t>(points)), candidates,
                 series_root_tolerance);
  const double mid = c.geometry.fit_mid[static_cast<std::size_t>(fit)];
  const double half = c.geometry.fit_half[static_cast<std::size_t>(fit)];
  for (std::size_t n = before; n < candidates.size(); ++n) candidates[n] = mid + half * candidates[n];
}

/// Bounds of φ and φ_x over intervals, summed term by term (W intervals, or W atoms, per vector).
template <class F>
struct interval_sums {
  F phi_low{}, phi_high{}, slope_low{}, slope_high{}, slope_scale{};
};

/// out = a where `mask` is set, b elsewhere (bitwise; an out-parameter, as vectors are never returned).
template <class F>
[[gnu::always_inline]] inline void blend(F& out, const simd::mask_of<F>& mask, const F& a, const F& b) {
  using M = simd::mask_of<F>;
  out = reinterpret_cast<F>((reinterpret_cast<M>(a) & mask) | (reinterpret_cast<M>(b) & ~mask));
}

/// Adds one atom's terms over the interval x ∈ [c + lo, c + hi] (offsets lo < hi from its centre c; e_lo, e_hi its
/// x factors e^(k·δx²) there, k = d/r²) to the bounds (eqs. 3–5 along a line, and their extension to φ_x): the
/// factor lies between its values at the nearest and farthest points of the interval; its slope 2k·δx·e^(k·δx²)
/// between its values at the ends, or its peak ±√(−2k)·e^(−1/2) at δx = ∓1/√(−2k) when the interval holds that
/// point. The atom adds to the upper bounds where its cutoff reaches the interval, to the lower bound of φ where it
/// covers the whole interval.
template <class F>
[[gnu::always_inline]] inline void add_interval_terms(const F& lo, const F& hi, const F& e_lo, const F& e_hi,
                                                      const F& k, const F& weight, const F& rho2, const F& cutoff2,
                                                      const F& peak_offset, const F& peak_slope,
                                                      interval_sums<F>& sums) {
  const F zero{}, one = zero + 1.0;
  F nearest, below, farthest;
  blend(nearest, lo > zero, lo, zero);
  blend(below, hi < zero, -hi, zero);
  nearest += below;
  blend(farthest, -lo > hi, -lo, hi);
  const auto reaches = nearest * nearest + rho2 < cutoff2;
  const auto covers = farthest * farthest + rho2 < cutoff2;
  F e_low, e_max, e_high;
  blend(e_low, e_lo < e_hi, e_lo, e_hi);
  blend(e_max, e_lo > e_hi, e_lo, e_hi);
  blend(e_high, (lo <= zero) & (hi >= zero), one, e_max);
  const F s_lo = 2 * k * lo * e_lo, s_hi = 2 * k * hi * e_hi;
  F s_min, s_max, s_low, s_high;
  blend(s_min, s_lo < s_hi, s_lo, s_hi);
  blend(s_max, s_lo > s_hi, s_lo, s_hi);
  blend(s_low, (lo <= peak_offset) & (hi >= peak_offset), -peak_slope, s_min);
  blend(s_high, (lo <= -peak_offset) & (hi >= -peak_offset), peak_slope, s_max);
  F high = weight * e_high, low = weight * e_low, slope_low = weight * s_low, slope_high = weight * s_high;
  F scale;
  blend(scale, -slope_low > slope_high, -slope_low, slope_high);
  simd::keep_lanes(high, reaches);
  simd::keep_lanes(low, covers);
  simd::keep_lanes(slope_low, reaches);
  simd::keep_lanes(slope_high, reaches);
  simd::keep_lanes(scale, reaches);
  sums.phi_high += high;
  sums.phi_low += low;
  sums.slope_low += slope_low;
  sums.slope_high += slope_high;
  sums.slope_scale += scale;
}

/// The bounds over [x_lo, x_hi] of the current line, from its atoms' factors at both ends (W atoms at a time).
template <int W>
[[gnu::always_inline]] inline interval_sums<double> bound_interval(const line_root_finder::workspace& ws, double x_lo,
                                                                   double x_hi) {
  using F = typename simd::pack<W>::f64;
  interval_sums<F> sums;
  const double half_decay = kernel_exp(-0.5);
  for (std::size_t a = 0; a < ws.line_count; a += W) {
    line_atom_pack<F> atoms;
    load_line_atoms(ws, a, atoms);
    const F &c = atoms.x, &k = atoms.d_inv_r2;
    // The slope's peak: at δx = ±1/√(−2k), of magnitude √(−2k)·e^(−1/2) (padding lanes: k = 0, weight = 0).
    F peak_offset{}, peak_slope{};
    for (int lane = 0; lane < W; ++lane) {
      const double root_rate = std::sqrt(-2 * k[lane]);
      peak_offset[lane] = root_rate > 0 ? 1 / root_rate : 0.0;
      peak_slope[lane] = root_rate * half_decay;
    }
    const F lo = x_lo - c, hi = x_hi - c;
    F e_lo = k * (lo * lo), e_hi = k * (hi * hi);
    simd::exp_in_place(e_lo);
    simd::exp_in_place(e_hi);
    add_interval_terms<F>(lo, hi, e_lo, e_hi, k, atoms.weight, atoms.dy2 + atoms.dz2, atoms.cutoff2, peak_offset,
                          peak_slope, sums);
  }
  return {simd::lane_sum(sums.phi_low), simd::lane_sum(sums.phi_high), simd::lane_sum(sums.slope_low),
          simd::lane_sum(sums.slope_high), simd::lane_sum(sums.slope_scale)};
}

using interval_proof = line_root_finder::interval_proof;

/// The proof from the curvature bound alone: |φ''| ≤ K on the line (K = Σ weight·2|d|/r², as |d²/dx² e^(d·δx²/r²)|
/// ≤ 2|d|/r²), so on [lo, lo + width] φ lies within K·width²/8 of the chord between its end values, and φ' within
/// K·width/2 of the chord's slope. `below`, `above`: φ − t0 at the ends.
interval_proof prove_by_curvature(double curvature, double width, double below, double above, double t0) {
  const double margin = bound_margin * t0;
  const bool opposite_ends = (below >= 0) != (above >= 0);
  if (!opposite_ends && std::min(std::abs(below), std::abs(above)) > curvature * width * width / 8 + margin) {
    return interval_proof::no_root;
  }
  if (std::abs(above - below) > curvature * width * width / 2 + margin) {
    return opposite_ends ? interval_proof::one_root : interval_proof::no_root;
  }
  return interval_proof::undecided;
}

/// The proof from the bounds of φ and φ_x over the interval (`b`, add_interval_terms).
interval_proof prove_by_bounds(const interval_sums<double>& b, double t0, double value_lo, double value_hi) {
  const bool opposite_ends = (value_lo >= t0) != (value_hi >= t0);
  const double slope_margin = bound_margin * b.slope_scale;
  if (b.slope_low > slope_margin || b.slope_high < -slope_margin) {
    return opposite_ends ? interval_proof::one_root : interval_proof::no_root;
  }
  if (b.phi_high < t0 * (1 - bound_margin) || b.phi_low > t0 * (1 + bound_margin)) return interval_proof::no_root;
  return interval_proof::undecided;
}

/// Proves the root count of [lo, hi] (φ = value_lo, value_hi at its ends), which the curvature bound left undecided,
/// from the bounds over it and, where they do not decide, over its halves (φ sampled at the middle), recursively;
/// appends the one-root pieces to ws.brackets in x order. A piece still undecided after max_interval_splits
/// halvings is counted by the signs at its ends.
template <int W>
[[gnu::always_inline]] inline void prove_interval(line_root_finder::workspace& ws, double t0, double curvature,
                                                  double lo, double value_lo, double hi, double value_hi,
                                                  line_root_stats& stats) {
  struct piece {
    double lo, value_lo, hi, value_hi;
    int splits;  ///< halvings that made it
  };
  // Depth first, left half first: at most one pending right half per level.
  std::array<piece, max_interval_splits + 1> pending;
  std::size_t count = 0;
  pending[count++] = {lo, value_lo, hi, value_hi, 0};
  while (count > 0) {
    const piece p = pending[--count];
    interval_proof proof =
        p.splits == 0 ? interval_proof::undecided
                      : prove_by_curvature(curvature, p.hi - p.lo, p.value_lo - t0, p.value_hi - t0, t0);
    if (proof == interval_proof::undecided) {
      proof = prove_by_bounds(bound_interval<W>(ws, p.lo, p.hi), t0, p.value_lo, p.value_hi);
    }
    if (proof == interval_proof::undecided && p.splits < max_interval_splits) {
      ++stats.split_intervals;
      const double mid = 0.5 * (p.lo + p.hi);
      const double value_mid = evaluate_line<W>(ws, mid).value;
      ++stats.field_evaluations;
      pending[count++] = {mid, value_mid, p.hi, p.value_hi, p.splits + 1};
      pending[count++] = {p.lo, p.value_lo, mid, value_mid, p.splits + 1};
      continue;
    }
    if (proof == interval_proof::undecided) {
      ++stats.tangent_intervals;
      proof = (p.value_lo >= t0) != (p.value_hi >= t0) ? interval_proof::one_root : interval_proof::no_root;
    }
    if (proof == interval_proof::one_root) ws.brackets.push_back({p.lo, p.hi, p.value_lo >= t0});
  }
}

/// The curvature bound's proof of each interval between consecutive samples of a line (`node_x`, exact φ `values`;
/// ws.proofs), except inside the pieces whose bounds (`pieces_proven`, bound_lines) already prove them root-free.
/// Returns whether any interval may hold a root (one_root or undecided).
bool prove_by_curvature(line_root_finder::workspace& ws, std::span<const double> node_x, const double* values,
                        double t0, const double* piece_curvature,
                        const std::array<double, bound_pieces + 1>& piece_edges,
                        const std::array<bool, bound_pieces>& pieces_proven) {
  ws.proofs.assign(node_x.size() - 1, interval_proof::no_root);
  ws.interval_curvature.resize(node_x.size() - 1);
  bool any = false;
  int piece = 0;
  for (std::size_t m = 0; m + 1 < node_x.size(); ++m) {
    const double lo = node_x[m], hi = node_x[m + 1];
    while (piece + 1 < bound_pieces && lo >= piece_edges[static_cast<std::size_t>(piece + 1)]) ++piece;
    const bool inside_one_piece = piece + 1 == bound_pieces || hi <= piece_edges[static_cast<std::size_t>(piece + 1)];
    if (inside_one_piece && pieces_proven[static_cast<std::size_t>(piece)]) continue;
    const double curvature = inside_one_piece ? piece_curvature[piece]
                                              : std::max(piece_curvature[piece], piece_curvature[piece + 1]);
    ws.interval_curvature[m] = curvature;
    const interval_proof proof = prove_by_curvature(curvature, hi - lo, values[m] - t0, values[m + 1] - t0, t0);
    ws.proofs[m] = proof;
    any |= proof != interval_proof::no_root;
  }
  return any;
}

/// The one-root intervals of the current line (ws.brackets, in x order; its atoms gathered) from the curvature
/// bound's proofs (ws.proofs) and, where they are undecided, prove_interval.
template <int W>
[[gnu::always_inline]] inline void find_brackets(line_root_finder::workspace& ws, std::span<const double> node_x,
                                                 const double* values, double t0, line_root_stats& stats) {
  ws.brackets.clear();
  for (std::size_t m = 0; m + 1 < node_x.size(); ++m) {
    switch (ws.proofs[m]) {
      case interval_proof::one_root:
        ws.brackets.push_back({node_x[m], node_x[m + 1], values[m] >= t0});
        break;
      case interval_proof::undecided:
        prove_interval<W>(ws, t0, ws.interval_curvature[m], node_x[m], values[m], node_x[m + 1], values[m + 1],
                          stats);
        break;
      case interval_proof::no_root:
        break;
    }
  }
}

/// The roots of the current line (ws.accepted, sorted and unique): one per bracket, solved from the series root
/// inside it (ws.candidates, sorted) or from its middle when the series has none there.
template <int W>
[[gnu::always_inline]] inline void solve_brackets(line_root_finder::workspace& ws, const block_geometry& geometry,
                                                  double t0, line_root_stats& stats) {
  std::vector<line_root>& found = ws.accepted;
  found.clear();
  std::sort(ws.candidates.begin(), ws.candidates.end());
  std::size_t used = 0;
  auto candidate = ws.candidates.begin();
  for (const line_root_finder::root_bracket& bracket : ws.brackets) {
    candidate = std::lower_bound(candidate, ws.candidates.end(), bracket.lo);
    const bool seeded = candidate != ws.candidates.end() && *candidate < bracket.hi;
    const double start = seeded ? *candidate : 0.5 * (bracket.lo + bracket.hi);
    line_root root{};
    if (!polish_bracket<W>(ws, t0, bracket.lo, bracket.lo_inside, bracket.hi, start, root, stats.field_evaluations) ||
        !(root.x >= geometry.x_lo && root.x < geometry.x_hi)) {
      continue;
    }
    found.push_back(root);
    ++(seeded ? stats.polynomial_roots : stats.bracketed_roots);
    used += seeded;
  }
  stats.rejected_roots += ws.candidates.size() - used;  // at most one candidate seeds each bracket
  sort_unique(found);
}

/// Appends the dips of one line (line_root_settings::dip_ratio) from its samples `values` at `node_x`.
void find_dips(int line, std::span<const double> node_x, const double* values, double t0, double dip_ratio,
               std::vector<block_line_roots::dip>& dips) {
  const double ceiling = dip_ratio * t0;
  for (std::size_t n = 1; n + 1 < node_x.size(); ++n) {
    const double v = values[n];
    if (v > t0 && v <= ceiling && v < values[n - 1] && v <= values[n + 1]) dips.push_back({line, node_x[n]});
  }
}

/// Which pieces of `line` the bounds of bound_lines prove free of roots (φ below or above t0 throughout).
std::array<bool, bound_pieces> proven_pieces(const line_root_finder::workspace& ws, int line, double t0) {
  std::array<bool, bound_pieces> proven{};
  const double* b = ws.bounds.data() + static_cast<std::size_t>(line) * simd::max_lanes;
  for (int p = 0; p < bound_pieces; ++p) {
    proven[static_cast<std::size_t>(p)] =
        b[p] < t0 * (1 - bound_margin) || b[bound_pieces + p] > t0 * (1 + bound_margin);
  }
  return proven;
}

}  // namespace

line_root_finder::line_root_finder(const line_root_settings& settings) : settings_(settings), fitter_(settings.degree) {
  // Values at the nodes → Legendre coefficients (eq. 6) → Bernstein coefficients, as one matrix stored by column
  // (node).
  const int count = fitter_.points();
  values_to_bernstein_.assign(static_cast<std::size_t>(count * count), 0.0);
  std::vector<double> unit(static_cast<std::size_t>(count)), a(unit.size()), b(unit.size());
  for (int m = 0; m < count; ++m) {
    std::fill(unit.begin(), unit.end(), 0.0);
    unit[static_cast<std::size_t>(m)] = 1;
    fitter_.coefficients(unit, a);
    legendre_to_bernstein(a, b);
    std::copy(b.begin(), b.end(), values_to_bernstein_.begin() + static_cast<std::ptrdiff_t>(m * count));
  }
}

void line_root_finder::find(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                            std::span<const std::uint32_t> atoms, block_line_roots& out, line_root_stats& stats) {
  workspace& ws = scratch_;
  // The samples of a line, ascending in x: the span's lower end, the nodes of each fit, the span's upper end (the
  // lower end of one block is the upper end of the previous one, computed from the same atoms in the same order, so
  // the two blocks agree on its sign).
  const int points = fitter_.points();
  const int samples = points * fits_per_line + 2;
  const int node_stride = static_cast<int>(padded_size(static_cast<std::size_t>(samples)));
  const block_geometry geometry = make_geometry(lat, block);
  const double h = lat.spacing(), t0 = field.t0();

  prepare_workspace(field, atoms, static_cast<std::size_t>(node_stride), ws);
  ws.node_x.assign(static_cast<std::size_t>(node_stride), geometry.x_hi + 1e6);  // padding: beyond every cutoff
  ws.node_x[0] = geometry.x_lo;
  ws.node_x[static_cast<std::size_t>(samples - 1)] = geometry.x_hi;
  for (int q = 0; q < fits_per_line; ++q) {
    for (int m = 0; m < points; ++m) {
      ws.node_x[static_cast<std::size_t>(1 + q * points + m)] =
          geometry.fit_mid[static_cast<std::size_t>(q)] +
          geometry.fit_half[static_cast<std::size_t>(q)] * fitter_.rule().nodes[static_cast<std::size_t>(m)];
    }
  }
  ws.legendre.resize(static_cast<std::size_t>(points));
  ws.bernstein.resize(static_cast<std::size_t>(points));
  const auto line_y = line_coordinates(block.j, h), line_z = line_coordinates(block.k, h);
  const std::size_t count = atoms.size(), stride = padded_size(count);
  const fit_context context{fitter_, values_to_bernstein_, geometry, t0};
  const std::span<const double> node_x(ws.node_x.data(), static_cast<std::size_t>(samples));
  out.roots.clear();
  out.dips.clear();
  out.first[0] = 0;

  std::array<double, bound_pieces + 1> piece_edges{};
  for (int p = 0; p <= bound_pieces; ++p) {
    piece_edges[static_cast<std::size_t>(p)] =
        static_cast<double>(block.i * lattice::block_cells + p * (lattice::block_cells / bound_pieces)) * h;
  }
  const double inside_level = std::max(t0, settings_.dip_ratio * t0);

  simd::dispatch([&](auto lanes) __attribute__((always_inline)) {
    constexpr int W = decltype(lanes)::value;
    line_factors<W>(field, ws, count, stride, line_y, line_z);
    bound_lines<W>(field, ws, count, piece_edges);
    const int sampled_lines = settings_.prove_root_free ? choose_sampled_lines(ws, t0, inside_level) : lines_per_block;
    if (!settings_.prove_root_free) ws.sampled.fill(1);
    sample_nodes<W>(field, ws, count, node_stride);
    stats.lines += lines_per_block;
    stats.proven_lines += static_cast<std::size_t>(lines_per_block - sampled_lines);
    stats.field_evaluations += static_cast<std::size_t>(sampled_lines) * static_cast<std::size_t>(samples);
    for (int line = 0; line < lines_per_block; ++line) {
      if (!ws.sampled[static_cast<std::size_t>(line)]) {  // no root and no dip (bound_lines)
        out.first[static_cast<std::size_t>(line + 1)] = static_cast<std::uint32_t>(out.roots.size());
        continue;
      }
      const double* values = ws.sums.data() + static_cast<std::size_t>(line) * static_cast<std::size_t>(node_stride);
      if (settings_.dip_ratio > 0) find_dips(line, node_x, values, t0, settings_.dip_ratio, out.dips);
      std::array<bool, bound_pieces> proven{};
      if (settings_.prove_root_free) proven = proven_pieces(ws, line, t0);
      if (std::find(proven.begin(), proven.end(), false) != proven.end()) {
        ws.candidates.clear();
        for (int q = 0; q < fits_per_line; ++q) {
          fit_candidates(context, q, values + 1 + q * points, ws.legendre, ws.bernstein, ws.candidates, stats);
        }
        const double* curvature = ws.curvature.data() + static_cast<std::size_t>(line) * bound_pieces;
        if (prove_by_curvature(ws, node_x, values, t0, curvature, piece_edges, proven)) {
          gather_line_atoms<W>(ws, count, stride, line % block_lines, line / block_lines, field.d());
          find_brackets<W>(ws, node_x, values, t0, stats);
          solve_brackets<W>(ws, geometry, t0, stats);
          out.roots.insert(out.roots.end(), ws.accepted.begin(), ws.accepted.end());
        } else {
          stats.rejected_roots += ws.candidates.size();
        }
      }
      out.first[static_cast<std::size_t>(line + 1)] = static_cast<std::uint32_t>(out.roots.size());
    }
  });
}

}  // namespace tracemesh
