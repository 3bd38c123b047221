#include "core/trace/untouched_cavities.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "core/field/band_culling.hpp"
#include "core/lattice/lattice.hpp"

namespace tracemesh {
namespace {

/// The descent stops when a step shrinks below this (Å) or the gradient below this × t0 per Å.
constexpr double descent_step_tolerance = 1e-9;
constexpr double descent_gradient_tolerance = 1e-10;
constexpr int max_descent_iterations = 100;
/// Armijo's sufficient-decrease constant.
constexpr double armijo = 1e-4;
/// Two minima closer than this (Å) are one.
constexpr double same_minimum = 1e-4;
/// The extent march's step, relative to h̃, before bisection to the crossing.
constexpr double extent_step = 0.05;
/// Points per face edge sampled before the proof (face_samples_above_level).
constexpr int face_samples = 9;
/// Face patches are cut down to this fraction of the box's smallest half width before a proof fails.
constexpr double min_patch_fraction = 1.0 / 128;

struct descent_result {
  vec3 point;
  double value = 0;
  bool converged = false;
};

/// BFGS on φ from `start` with a backtracking (Armijo) line search, its steps at most `max_step` Å. Stops once the
/// point is farther than `max_travel` from the start (not converged: the pocket is not near the line).
descent_result descend(const gaussian_field& field, const vec3& start, double max_step, double max_travel,
                       std::size_t& evaluations) {
  vec3 p = start, g;
  double f = field.value_and_gradient(p, g);
  ++evaluations;
  // Inverse Hessian estimate, row-major; starts as the identity (steepest descent).
  std::array<double, 9> H{1, 0, 0, 0, 1, 0, 0, 0, 1};
  const auto times = [&H](const vec3& v) {
    return vec3{H[0] * v.x + H[1] * v.y + H[2] * v.z, H[3] * v.x + H[4] * v.y + H[5] * v.z,
                H[6] * v.x + H[7] * v.y + H[8] * v.z};
  };
  for (int iteration = 0; iteration < max_descent_iterations; ++iteration) {
    if (norm(g) <= descent_gradient_tolerance * field.t0()) return {p, f, true};
    vec3 direction = -times(g);
    if (dot(direction, g) >= 0) {  // not a descent direction: restart from steepest descent
      H = {1, 0, 0, 0, 1, 0, 0, 0, 1};
      direction = -g;
    }
    double length = norm(direction);
    double t = length > max_step ? max_step / length : 1.0;
    vec3 q, gq;
    double fq = 0;
    for (;;) {
      q = p + direction * t;
      fq = field.value_and_gradient(q, gq);
      ++evaluations;
      if (fq <= f + armijo * t * dot(direction, g)) break;
      t *= 0.5;
      if (t * length < descent_step_tolerance) return {p, f, true};
    }
    const vec3 s = q - p, y = gq - g;
    p = q;
    f = fq;
    g = gq;
    if (squared_norm(p - start) > max_travel * max_travel) return {p, f, false};
    if (norm(s) < descent_step_tolerance) return {p, f, true};
    const double sy = dot(s, y);
    if (sy <= 0) continue;  // curvature condition fails: keep H
    // H ← (I − ρ s yᵀ) H (I − ρ y sᵀ) + ρ s sᵀ, ρ = 1 / (sᵀy).
    const double rho = 1 / sy;
    const vec3 hy = times(y);
    const double yhy = dot(y, hy);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        H[static_cast<std::size_t>(3 * r + c)] +=
            rho * ((1 + rho * yhy) * s[r] * s[c] - hy[r] * s[c] - s[r] * hy[c]);
      }
    }
  }
  return {p, f, false};
}

/// How far φ stays below t0 from `minimum` along `direction` (a unit axis vector): the distance to the first
/// crossing, found by marching `step` at a time and bisecting; nullopt beyond `max_distance`.
std::optional<double> extent_along(const gaussian_field& field, const vec3& minimum, const vec3& direction,
                                   double step, double max_distance, std::size_t& evaluations) {
  const double t0 = field.t0();
  double inside = 0;
  for (double t = step; t <= max_distance + step; t += step) {
    ++evaluations;
    if (field.value(minimum + direction * t) >= t0) {
      double lo = inside, hi = t;
      for (int n = 0; n < 40 && hi - lo > 1e-6; ++n) {
        const double mid = 0.5 * (lo + hi);
        ++evaluations;
        (field.value(minimum + direction * mid) >= t0 ? hi : lo) = mid;
      }
      return hi <= max_distance ? std::optional<double>(hi) : std::nullopt;
    }
    inside = t;
  }
  return std::nullopt;
}

/// The pocket's reach from `minimum` along −x, +x, −y, +y, −z, +z; nullopt when it reaches beyond `max_distance`.
std::optional<std::array<double, 6>> pocket_extent(const gaussian_field& field, const vec3& minimum, double step,
                                                   double max_distance, std::size_t& evaluations) {
  std::array<double, 6> reach{};
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      vec3 direction;
      direction[axis] = side == 0 ? -1.0 : 1.0;
      const auto r = extent_along(field, minimum, direction, step, max_distance, evaluations);
      if (!r) return std::nullopt;
      reach[static_cast<std::size_t>(2 * axis + side)] = *r;
    }
  }
  return reach;
}

/// The box for a pocket: at least `half_yz` around the minimum in y and z and `half_x` in x, made of whole blocks of
/// the local grid of `spacing`, centred on the minimum in y and z so that a line of that grid passes through it.
untouched_cavity box_around(const vec3& minimum, double half_yz, double half_x, double spacing) {
  constexpr int half_block = lattice::block_cells / 2;
  untouched_cavity c;
  c.minimum = minimum;
  c.spacing = spacing;
  const double block = lattice::block_cells * spacing;
  c.blocks_yz = std::max(1, static_cast<int>(std::ceil(half_yz / (half_block * spacing))));
  c.blocks_x = std::max(1, static_cast<int>(std::ceil(2 * half_x / block)));
  const double half = c.blocks_yz * half_block * spacing;
  const double x_lo = minimum.x - 0.5 * c.blocks_x * block;
  c.box.lo = {x_lo, minimum.y - half, minimum.z - half};
  c.box.hi = {x_lo + c.blocks_x * block, minimum.y + half, minimum.z + half};
  return c;
}

/// The atoms of `candidates` whose cutoff sphere reaches `box`.
void atoms_reaching(const gaussian_field& field, std::span<const std::uint32_t> candidates, const box3& box,
                    std::vector<std::uint32_t>& out) {
  out.clear();
  for (const std::uint32_t k : candidates) {
    const gaussian_field::atom_data a = field.atom_at(k);
    const vec3 c{a.x, a.y, a.z};
    double d2 = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double below = box.lo[axis] - c[axis], above = c[axis] - box.hi[axis];
      const double gap = std::max({below, above, 0.0});
      d2 += gap * gap;
    }
    if (d2 < a.cutoff2) out.push_back(k);
  }
}

/// A lower bound of the cut-off field on the flat patch `patch` in its centred (Taylor) form: with c the patch's
/// centre and δ = x − c, φ(x) ≥ φ(c) − |∇φ(c)·δ| − ½·M·|δ|², where M bounds |vᵀ∇²φ v| over the patch for unit v.
/// Summed over the atoms whose cutoff sphere holds the whole patch (smooth there; every other atom adds ≥ 0). Per
/// atom, with a = −d/r² and k = e^(−d)·e^(−a·ρ²) at distance ρ, vᵀ∇²k v = k·(4a²(v·δᵢ)² − 2a), so
/// |vᵀ∇²k v| ≤ 2a·max(k, 2a·ρ²·k), and over the patch k is largest at its nearest point and ρ²·k at
/// ρ² = 1/a clamped to the patch's range of ρ². The gradient term keeps the cancellation between atoms that the
/// per-atom extremes of eqs. 3–5 lose, so deep inside the molecule, where many atoms pull in different directions,
/// it proves a face with far fewer patches.
double centred_lower_bound(const gaussian_field& field, const box3& patch, std::span<const std::uint32_t> atoms) {
  const vec3 centre = (patch.lo + patch.hi) * 0.5;
  const vec3 half = (patch.hi - patch.lo) * 0.5;
  const double scale = kernel_exp(-field.d());
  double value = 0, curvature = 0;
  vec3 gradient{};
  for (const std::uint32_t k : atoms) {
    const gaussian_field::atom_data atom = field.atom_at(k);
    const vec3 offset = centre - vec3{atom.x, atom.y, atom.z};
    double near2 = 0, far2 = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double gap = std::max(std::abs(offset[axis]) - half[axis], 0.0);
      const double reach = std::abs(offset[axis]) + half[axis];
      near2 += gap * gap;
      far2 += reach * reach;
    }
    if (!(far2 < atom.cutoff2)) continue;  // cut off somewhere on the patch: it adds ≥ 0
    const double a = -field.d() * atom.inv_r2;
    const double kernel = scale * kernel_exp(-a * squared_norm(offset));
    value += kernel;
    gradient += offset * (-2 * a * kernel);
    const double peak2 = std::clamp(1 / a, near2, far2);
    const double largest_kernel = scale * kernel_exp(-a * near2);
    curvature += 2 * a * std::max(largest_kernel, 2 * a * peak2 * scale * kernel_exp(-a * peak2));
  }
  const double linear = std::abs(gradient.x) * half.x + std::abs(gradient.y) * half.y + std::abs(gradient.z) * half.z;
  return value - linear - 0.5 * curvature * squared_norm(half);
}

/// True when a lower bound of the field on the flat patch `patch` (or on its quarters, recursively) exceeds t0:
/// eqs. 3–5, or the centred form (centred_lower_bound). `atoms`: every atom whose cutoff sphere reaches the patch;
/// each quarter sums only those that reach it.
bool patch_above_level(const gaussian_field& field, const box3& patch, int flat_axis, double min_patch,
                       std::span<const std::uint32_t> atoms) {
  constexpr double no_upper_bound = std::numeric_limits<double>::infinity();
  if (bounds_exclude({centred_lower_bound(field, patch, atoms), no_upper_bound}, field.t0())) return true;
  const field_bounds bounds = bound_field_on_box(field, patch, atoms);
  if (bounds.lower > field.t0() && bounds_exclude(bounds, field.t0())) return true;
  const int a = (flat_axis + 1) % 3, b = (flat_axis + 2) % 3;
  if (patch.hi[a] - patch.lo[a] <= min_patch && patch.hi[b] - patch.lo[b] <= min_patch) return false;
  const double mid_a = 0.5 * (patch.lo[a] + patch.hi[a]), mid_b = 0.5 * (patch.lo[b] + patch.hi[b]);
  std::vector<std::uint32_t> quarter_atoms;
  for (int qa = 0; qa < 2; ++qa) {
    for (int qb = 0; qb < 2; ++qb) {
      box3 quarter = patch;
      (qa == 0 ? quarter.hi : quarter.lo)[a] = mid_a;
      (qb == 0 ? quarter.hi : quarter.lo)[b] = mid_b;
      atoms_reaching(field, atoms, quarter, quarter_atoms);
      if (!patch_above_level(field, quarter, flat_axis, min_patch, quarter_atoms)) return false;
    }
  }
  return true;
}

/// True when φ > t0 at face_samples² points of each face of `box` (corners and edges included): a quick way to
/// refuse a box whose faces do meet the pocket, before the bounds are subdivided to their finest patches.
bool face_samples_above_level(const gaussian_field& field, const box3& box) {
  for (int axis = 0; axis < 3; ++axis) {
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      for (int u = 0; u < face_samples; ++u) {
        for (int v = 0; v < face_samples; ++v) {
          vec3 p;
          p[axis] = side == 0 ? box.lo[axis] : box.hi[axis];
          p[a] = box.lo[a] + (box.hi[a] - box.lo[a]) * u / (face_samples - 1);
          p[b] = box.lo[b] + (box.hi[b] - box.lo[b]) * v / (face_samples - 1);
          if (field.value(p) <= field.t0()) return false;
        }
      }
    }
  }
  return true;
}

/// True when some root of `lines` lies in `box` (the main mesh has a piece there).
bool holds_a_root(const trace_lines& lines, double h, const box3& box) {
  const auto first = static_cast<std::int64_t>(std::ceil(box.lo.y / h));
  const auto last = static_cast<std::int64_t>(std::floor(box.hi.y / h));
  const auto first_k = static_cast<std::int64_t>(std::ceil(box.lo.z / h));
  const auto last_k = static_cast<std::int64_t>(std::floor(box.hi.z / h));
  for (std::int64_t j = first; j <= last; ++j) {
    for (std::int64_t k = first_k; k <= last_k; ++k) {
      for (const line_point& p : lines.roots_of({j, k})) {
        if (p.x >= box.lo.x && p.x <= box.hi.x) return true;
      }
    }
  }
  return false;
}

/// The distinct minima below t0 among the descents, in a fixed order (by x, then y, then z).
std::vector<vec3> distinct_pockets(const std::vector<descent_result>& descents, double t0) {
  std::vector<vec3> minima;
  for (const descent_result& d : descents) {
    if (d.converged && d.value < t0) minima.push_back(d.point);
  }
  std::sort(minima.begin(), minima.end(), [](const vec3& a, const vec3& b) {
    return a.x < b.x || (a.x == b.x && (a.y < b.y || (a.y == b.y && a.z < b.z)));
  });
  std::vector<vec3> distinct;
  for (const vec3& m : minima) {
    const bool known = std::any_of(distinct.rbegin(), distinct.rend(), [&](const vec3& q) {
      return m.x - q.x <= same_minimum && distance(m, q) <= same_minimum;
    });
    if (!known) distinct.push_back(m);
  }
  return distinct;
}

/// The proven box of the pocket at `minimum`, if it is a void smaller than max_extent·h̃ whose box the bounds prove.
std::optional<untouched_cavity> prove_pocket(const gaussian_field& field, const trace_lines& lines,
                                             const vec3& minimum, double h, const untouched_cavity_settings& settings,
                                             std::size_t& evaluations) {
  const auto reach = pocket_extent(field, minimum, extent_step * h, settings.max_extent * h, evaluations);
  if (!reach) return std::nullopt;
  // A line with a root inside the pocket's reach has met it: the main mesh holds it already (no proof needed).
  const box3 reach_box{minimum - vec3{(*reach)[0], (*reach)[2], (*reach)[4]},
                       minimum + vec3{(*reach)[1], (*reach)[3], (*reach)[5]}};
  if (holds_a_root(lines, h, reach_box)) return std::nullopt;
  const double reach_x = std::max((*reach)[0], (*reach)[1]);
  const double reach_yz = std::max({(*reach)[2], (*reach)[3], (*reach)[4], (*reach)[5]});
  const double narrowest_yz = std::min({(*reach)[2], (*reach)[3], (*reach)[4], (*reach)[5]});
  const double spacing = std::min(settings.max_local_spacing * h, settings.local_spacing * narrowest_yz);
  double margin = settings.box_margin;
  for (int attempt = 0; attempt < settings.box_tries; ++attempt, margin *= settings.box_growth) {
    const untouched_cavity c = box_around(minimum, margin * reach_yz, margin * reach_x, spacing);
    if (holds_a_root(lines, h, c.box)) return std::nullopt;  // a larger box would hold it too
    const double min_patch = min_patch_fraction * margin * std::min(reach_x, reach_yz);
    if (box_faces_above_level(field, c.box, min_patch)) return c;
  }
  return std::nullopt;
}

}  // namespace

bool box_faces_above_level(const gaussian_field& field, const box3& box, double min_patch) {
  if (!face_samples_above_level(field, box)) return false;
  std::vector<std::uint32_t> atoms;
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      box3 face = box;
      face.lo[axis] = face.hi[axis] = side == 0 ? box.lo[axis] : box.hi[axis];
      field.atoms_near_box(face, atoms);
      if (!patch_above_level(field, face, axis, min_patch, atoms)) return false;
    }
  }
  return true;
}

std::vector<untouched_cavity> find_untouched_cavities(const gaussian_field& field, const trace_lines& lines,
                                                      double spacing, std::span<const vec3> seeds,
                                                      const untouched_cavity_settings& settings,
                                                      progress_token& progress, untouched_cavity_stats& stats) {
  stats.seeds += seeds.size();
  std::vector<descent_result> descents(seeds.size());
  std::vector<std::size_t> evaluations(seeds.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, seeds.size(), 16), [&](const tbb::blocked_range<std::size_t>& r) {
    if (progress.cancelled()) return;
    for (std::size_t n = r.begin(); n != r.end(); ++n) {
      descents[n] = descend(field, seeds[n], 0.25 * spacing, settings.max_extent * spacing, evaluations[n]);
    }
  });
  for (const std::size_t e : evaluations) stats.field_evaluations += e;
  if (progress.cancelled()) return {};

  const std::vector<vec3> pockets = distinct_pockets(descents, field.t0());
  stats.pockets += pockets.size();
  std::vector<std::optional<untouched_cavity>> proven(pockets.size());
  std::vector<std::size_t> proof_evaluations(pockets.size(), 0);
  tbb::parallel_for(std::size_t{0}, pockets.size(), [&](std::size_t n) {
    if (!progress.cancelled()) proven[n] = prove_pocket(field, lines, pockets[n], spacing, settings, proof_evaluations[n]);
  });
  for (const std::size_t e : proof_evaluations) stats.field_evaluations += e;
  if (progress.cancelled()) return {};

  std::vector<untouched_cavity> cavities;
  for (const auto& c : proven) {
    if (!c) continue;
    const bool inside_earlier = std::any_of(cavities.begin(), cavities.end(), [&](const untouched_cavity& e) {
      return e.box.contains(c->minimum) || c->box.contains(e.minimum);
    });
    if (!inside_earlier) cavities.push_back(*c);
  }
  return cavities;
}

}  // namespace tracemesh
