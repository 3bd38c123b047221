#include "core/lattice/edge_root.hpp"

#include <algorithm>
#include <cmath>

#include "core/lattice/lattice_sampler.hpp"

namespace tracemesh {
namespace {

/// Relative slack when dropping atoms whose cutoff sphere misses a cube or an edge: rounding in the per-point test
/// r² < cutoff² can never reach it, so a dropped atom would have contributed nothing anywhere on the edge.
constexpr double reach_slack = 1e-9;
/// Newton-type iterations per root at most (each one evaluates the field along the edge once).
constexpr int max_root_iterations = 60;
/// Stop once the bracket or the step is this small (in units of the edge).
constexpr double root_tolerance = 1e-12;
/// A step this small (in units of the edge) of the third-order iteration leaves an error ~K·step³ of about 1e-9 Å:
/// take it and stop. (1e-6 cost 2.35 field passes per root instead of 1.93; the normal of the last evaluation, at most
/// this far from the root, only guides the quality pass: the certificate recomputes every output normal.)
constexpr double final_step = 1e-3;

/// The block's atoms as parallel arrays, padded with never-contributing entries (cutoff2 = 0) to whole vectors.
struct block_columns {
  std::vector<double> x, y, z, d_inv_r2, cutoff2;
  std::size_t count = 0;
};

/// The atoms whose cutoff sphere reaches one cube, as offsets o = origin − c from the cube's lowest corner: along
/// the edge origin + tΔ, |origin + tΔ − c|² = A + 2tB + t²C with A = |o|², B = o·Δ, C = |Δ|². Same padding.
struct cube_columns {
  std::vector<double> ox, oy, oz, a, d_inv_r2, cutoff2;
  std::vector<double> b;  ///< B of the edge being solved
  std::size_t count = 0;
};

/// φ, dφ/dt and d²φ/dt² at one t, and the direction of ∇φ there (unscaled).
struct edge_sample {
  double value, slope, curvature;
  vec3 gradient_direction;
};

/// A root on an edge: its parameter and the field normal −∇φ/|∇φ| there.
struct edge_solution {
  double t;
  vec3 normal;
};

std::size_t padded_size(std::size_t n) { return (n + simd::max_lanes - 1) / simd::max_lanes * simd::max_lanes; }

/// Copies the block's atoms (field-internal indices) into columns, with d/r² in place of 1/r².
void gather_block_atoms(const gaussian_field& field, std::span<const std::uint32_t> atoms, block_columns& out) {
  out.count = atoms.size();
  for (auto* column : {&out.x, &out.y, &out.z, &out.d_inv_r2, &out.cutoff2}) column->assign(padded_size(out.count), 0.0);
  const gaussian_field::atom_arrays all = field.atoms();
  for (std::size_t n = 0; n < atoms.size(); ++n) {
    const std::uint32_t k = atoms[n];
    out.x[n] = all.x[k];
    out.y[n] = all.y[k];
    out.z[n] = all.z[k];
    out.d_inv_r2[n] = field.d() * all.inv_r2[k];
    out.cutoff2[n] = all.cutoff2[k];
  }
}

/// Per lane: distance from c to the interval [lo, hi] (0 inside).
template <class F>
[[gnu::always_inline]] inline void interval_gap(F& c, double lo, double hi) {
  using M = simd::mask_of<F>;
  const F below = lo - c, above = c - hi;
  const M use_below = below > 0.0, use_above = above > 0.0;
  c = reinterpret_cast<F>((reinterpret_cast<M>(below) & use_below) | (reinterpret_cast<M>(above) & use_above));
}

/// The atoms of the block whose cutoff sphere reaches the cube [origin, origin + h]³ (every edge the cube owns lies
/// inside it). `out`'s columns must hold padded_size(block.count) entries.
template <int W>
[[gnu::always_inline]] inline void gather_cube_atoms(const block_columns& block, const vec3& origin, double h,
                                                     cube_columns& out) {
  using F = typename simd::pack<W>::f64;
  using M = typename simd::pack<W>::i64;
  std::size_t kept = 0;
  for (std::size_t k = 0; k < block.count; k += W) {
    F gx, gy, gz, cutoff2;
    simd::load(gx, block.x.data() + k);
    simd::load(gy, block.y.data() + k);
    simd::load(gz, block.z.data() + k);
    simd::load(cutoff2, block.cutoff2.data() + k);
    interval_gap(gx, origin.x, origin.x + h);
    interval_gap(gy, origin.y, origin.y + h);
    interval_gap(gz, origin.z, origin.z + h);
    M reaches = gx * gx + gy * gy + gz * gz < cutoff2 * (1 + reach_slack);
    simd::clear_lanes_from(reaches, static_cast<std::int64_t>(k), static_cast<std::int64_t>(block.count));
    if (!simd::any_lane(reaches)) continue;
    for (int j = 0; j < W; ++j) {
      if (!reaches[j]) continue;
      const vec3 offset{origin.x - block.x[k + j], origin.y - block.y[k + j], origin.z - block.z[k + j]};
      out.ox[kept] = offset.x;
      out.oy[kept] = offset.y;
      out.oz[kept] = offset.z;
      out.a[kept] = squared_norm(offset);
      out.d_inv_r2[kept] = block.d_inv_r2[k + j];
      out.cutoff2[kept] = block.cutoff2[k + j];
      ++kept;
    }
  }
  for (std::size_t k = kept; k < padded_size(kept); ++k) out.cutoff2[k] = 0;  // padding never contributes
  out.count = kept;
}

/// B = o·Δ of every cube atom for the edge Δ.
template <int W>
[[gnu::always_inline]] inline void edge_offsets(cube_columns& cube, const vec3& delta) {
  using F = typename simd::pack<W>::f64;
  for (std::size_t k = 0; k < cube.count; k += W) {
    F ox, oy, oz;
    simd::load(ox, cube.ox.data() + k);
    simd::load(oy, cube.oy.data() + k);
    simd::load(oz, cube.oz.data() + k);
    const F b = ox * delta.x + oy * delta.y + oz * delta.z;
    simd::store(cube.b.data() + k, b);
  }
}

/// φ(t), φ'(t), φ''(t) along the edge and ∇φ at origin + tΔ, each atom cut off exactly as gaussian_field does
/// (r² < cutoff²). With g(t) = (d/r²)·r²(t): kernel' = g'·kernel and kernel'' = (g'' + g'²)·kernel; ∇ of the kernel
/// is 2(d/r²)(p − c)·kernel with p − c = o + tΔ. The gradient rides along with the exponentials already paid for:
/// the last evaluation of a root gives its normal, which saves the remesher a field evaluation per vertex.
template <int W>
[[gnu::always_inline]] inline edge_sample evaluate_edge(const cube_columns& cube, const vec3& delta, double c,
                                                        double scale, double t) {
  using F = typename simd::pack<W>::f64;
  F value{}, slope{}, curvature{}, gx{}, gy{}, gz{};
  for (std::size_t k = 0; k < cube.count; k += W) {
    F ox, oy, oz, a, b, d_inv_r2, cutoff2;
    simd::load(ox, cube.ox.data() + k);
    simd::load(oy, cube.oy.data() + k);
    simd::load(oz, cube.oz.data() + k);
    simd::load(a, cube.a.data() + k);
    simd::load(b, cube.b.data() + k);
    simd::load(d_inv_r2, cube.d_inv_r2.data() + k);
    simd::load(cutoff2, cube.cutoff2.data() + k);
    const F r2 = a + t * (2 * b + t * c);
    F kernel = d_inv_r2 * r2;
    simd::exp_in_place(kernel);
    simd::keep_lanes(kernel, r2 < cutoff2);
    const F g1 = 2 * d_inv_r2 * (b + t * c);
    value += kernel;
    slope += g1 * kernel;
    curvature += (2 * c * d_inv_r2 + g1 * g1) * kernel;
    const F s = 2 * d_inv_r2 * kernel;
    gx += s * (ox + t * delta.x);
    gy += s * (oy + t * delta.y);
    gz += s * (oz + t * delta.z);
  }
  return {scale * simd::lane_sum(value), scale * simd::lane_sum(slope), scale * simd::lane_sum(curvature),
          vec3{simd::lane_sum(gx), simd::lane_sum(gy), simd::lane_sum(gz)}};
}

/// The root in t ∈ [0, 1] of the parabola through (s0, l0), (s0 + 1, l1), (s0 + 2, l2) equal to `level`
/// (the edge is [0, 1] and s0 ∈ {−1, 0}); −1 when none is found.
double parabola_root(double l0, double l1, double l2, double s0, double level) {
  // In u = t − s0: q(u) = a u² + b u + c − level.
  const double a = 0.5 * (l0 - 2 * l1 + l2), b = 0.5 * (-3 * l0 + 4 * l1 - l2), c = l0 - level;
  const double discriminant = b * b - 4 * a * c;
  if (!(discriminant >= 0)) return -1;
  const double q = -0.5 * (b + std::copysign(std::sqrt(discriminant), b));  // stable quadratic formula
  for (const double u : {q != 0 ? c / q : -1.0, a != 0 ? q / a : -1.0}) {
    const double t = u + s0;
    if (t >= 0 && t <= 1) return t;
  }
  return -1;
}

/// First guess of the root on an edge whose end points have values v0 and v1, given the next lattice value on the
/// same line (`third`, at t = −1 or t = 2 as `third_t` says; 0 if unknown). ln φ is close to a parabola along a
/// line (exactly one for a single atom), so the guess interpolates ln φ quadratically through the three values;
/// it falls back to ln φ linearly, then to φ linearly, where values are 0.
double first_guess(double v0, double v1, double third, int third_t, double t0) {
  const double linear = (v0 - t0) / (v0 - v1);
  if (!(v0 > 0 && v1 > 0)) return linear;
  const double l0 = std::log(v0), l1 = std::log(v1), level = std::log(t0);
  if (third > 0) {
    const double l2 = std::log(third);
    const double t = third_t < 0 ? parabola_root(l2, l0, l1, -1, level) : parabola_root(l0, l1, l2, 0, level);
    if (t >= 0) return t;
  }
  return (l0 - level) / (l0 - l1);
}

/// Root of φ = t0 on [0, 1] where φ(inside_t) ≥ t0 > φ(outside_t), from `guess`. Each step solves the quadratic
/// Taylor model of L(t) = ln(φ/t0) (from φ, φ', φ''; exact for one atom, third-order in general): from the
/// interpolated guess, two or three field evaluations. Steps stay inside the shrinking bracket, bisecting when
/// one would leave it. The normal is that of the last evaluation, at most final_step (in units of the edge) from
/// the root returned.
template <int W>
[[gnu::always_inline]] inline edge_solution solve_edge(const cube_columns& cube, const vec3& delta, double c,
                                                       double scale, double t0, double inside_t, double outside_t,
                                                       double guess) {
  double t = guess;
  vec3 gradient{};
  for (int iteration = 0; iteration < max_root_iterations; ++iteration) {
    const edge_sample s = evaluate_edge<W>(cube, delta, c, scale, t);
    gradient = s.gradient_direction;
    const double residual = s.value - t0;
    if (residual == 0) break;
    (residual > 0 ? inside_t : outside_t) = t;
    if (std::abs(outside_t - inside_t) < root_tolerance) break;
    double step = 0.5 * (inside_t + outside_t) - t;  // bisection unless the model does better
    bool model_step = false;
    if (s.value > 0 && s.slope != 0) {
      const double l = std::log(s.value / t0), l1 = s.slope / s.value, l2 = s.curvature / s.value - l1 * l1;
      const double discriminant = l1 * l1 - 2 * l * l2;  // l + l1·u + l2/2·u² = 0, root nearest u = 0
      step = discriminant >= 0 ? -2 * l / (l1 + std::copysign(std::sqrt(discriminant), l1)) : -l / l1;
      model_step = true;
    }
    double next = t + step;
    if (!(next > std::min(inside_t, outside_t) && next < std::max(inside_t, outside_t))) {
      next = 0.5 * (inside_t + outside_t);  // left the bracket: bisect
      model_step = false;
    }
    // Only a model step this short leaves a ~step³ error; a bisection step's error is the step itself (at coarse
    // densities a 1e-3 edge is 2–5e-3 Å, beyond the certificate's 1e-3 Å), so bisection goes on to root_tolerance.
    const bool converged = model_step && std::abs(next - t) < final_step;
    t = next;
    if (converged) break;
  }
  return {std::clamp(t, edge_root_margin, 1 - edge_root_margin), normalized(-gradient)};
}

template <int W>
[[gnu::always_inline]] inline void solve_block_roots_lanes(const gaussian_field& field, const lattice& lat,
                                                           const lattice_index& block,
                                                           std::span<const std::uint32_t> atoms,
                                                           std::span<const double> values,
                                                           std::vector<edge_vertex>& out) {
  constexpr int n = block_points;
  const double t0 = field.t0();
  const double h = lat.spacing();
  const double scale = kernel_exp(-field.d());  // e^(−d): the "− 1" of eq. 2
  const auto value_at = [&](int x, int y, int z) { return values[static_cast<std::size_t>((z * n + y) * n + x)]; };
  const auto inside_block = [](int x, int y, int z) {
    return x >= 0 && y >= 0 && z >= 0 && x < n && y < n && z < n;
  };
  // The lattice value next to the edge p → p + dir on its line: at t = −1 if that point is in the block, else at
  // t = 2; value 0 if neither is.
  struct line_neighbour {
    double value;
    int t;
  };
  const auto neighbour_of = [&](int x, int y, int z, const std::array<int, 3>& dir) -> line_neighbour {
    if (inside_block(x - dir[0], y - dir[1], z - dir[2])) return {value_at(x - dir[0], y - dir[1], z - dir[2]), -1};
    const int ax = x + 2 * dir[0], ay = y + 2 * dir[1], az = z + 2 * dir[2];
    return {inside_block(ax, ay, az) ? value_at(ax, ay, az) : 0.0, 2};
  };
  block_columns block_atoms;
  gather_block_atoms(field, atoms, block_atoms);
  cube_columns cube_atoms;
  for (auto* column : {&cube_atoms.ox, &cube_atoms.oy, &cube_atoms.oz, &cube_atoms.a, &cube_atoms.d_inv_r2,
                       &cube_atoms.cutoff2, &cube_atoms.b}) {
    column->resize(block_atoms.x.size());
  }
  for (int z = 0; z < lattice::block_cells; ++z) {
    for (int y = 0; y < lattice::block_cells; ++y) {
      for (int x = 0; x < lattice::block_cells; ++x) {
        const double v0 = value_at(x, y, z);
        bool gathered = false;
        const lattice_index p{block.i * lattice::block_cells + x, block.j * lattice::block_cells + y,
                              block.k * lattice::block_cells + z};
        const vec3 origin = lat.point(p);
        for (int direction = 0; direction < 7; ++direction) {
          const auto& dir = edge_directions[direction];
          const double v1 = value_at(x + dir[0], y + dir[1], z + dir[2]);
          if ((v0 >= t0) == (v1 >= t0)) continue;
          if (!gathered) {  // every edge the cube owns lies inside it
            gather_cube_atoms<W>(block_atoms, origin, h, cube_atoms);
            gathered = true;
          }
          const vec3 delta{dir[0] * h, dir[1] * h, dir[2] * h};
          edge_offsets<W>(cube_atoms, delta);
          const double c = squared_norm(delta);
          const line_neighbour third = neighbour_of(x, y, z, dir);
          const double guess = first_guess(v0, v1, third.value, third.t, t0);
          const edge_solution root = v0 >= t0 ? solve_edge<W>(cube_atoms, delta, c, scale, t0, 0.0, 1.0, guess)
                                              : solve_edge<W>(cube_atoms, delta, c, scale, t0, 1.0, 0.0, guess);
          out.push_back({lat.edge_key(p, direction), origin + delta * root.t, root.normal});
        }
      }
    }
  }
}

}  // namespace

void solve_block_roots(const gaussian_field& field, const lattice& lat, const lattice_index& block,
                       std::span<const std::uint32_t> atoms, std::span<const double> values,
                       std::vector<edge_vertex>& out) {
  simd::dispatch([&](auto lanes) __attribute__((always_inline)) {
    solve_block_roots_lanes<decltype(lanes)::value>(field, lat, block, atoms, values, out);
  });
}

}  // namespace tracemesh
