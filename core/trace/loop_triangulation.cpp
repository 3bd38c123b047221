#include "core/trace/loop_triangulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tracemesh {
namespace {

/// Value of a sub-polygon / band state that cannot be triangulated under the rules (every q is ≥ 0).
constexpr double infeasible = -1;
/// Worst quality of an empty triangulation (a sub-polygon that is a single loop edge): above every q.
constexpr double empty_worst = 2;
/// Pass 2 keeps triangles with q ≥ q*·(1 − this): immune to any difference in rounding between the passes.
constexpr double tie_tolerance = 1e-12;

/// The rules' thresholds, in the squared forms evaluate_triangle compares with.
struct rule_limits {
  double min_edge2;   ///< min_edge_length²
  double area_coef;   ///< |cross|² ≥ area_coef · longest⁴  ⇔  area ≥ min_area_ratio · longest²
  double cos2;        ///< min_normal_cosine²: cos > c compared as dot² against c² · |cross|² · |Σn|²
  enum class rule2 { non_negative, negative, off } orientation;  ///< sign of min_normal_cosine; off when ≤ −1
  bool agreement_objective;  ///< loop_triangulation_settings::maximise_normal_agreement

  explicit rule_limits(const loop_triangulation_settings& s)
      : min_edge2(s.min_edge_length * s.min_edge_length),
        area_coef(4 * s.min_area_ratio * s.min_area_ratio),
        cos2(s.min_normal_cosine * s.min_normal_cosine),
        orientation(s.min_normal_cosine >= 0  ? rule2::non_negative
                    : s.min_normal_cosine > -1 ? rule2::negative
                                               : rule2::off),
        agreement_objective(s.maximise_normal_agreement) {}
};

/// Whether triangle a, b, c faces against the normals at all three corners: a fold, which the certificate refuses
/// (analysis_local_folds.hpp), and no triangulation here makes.
inline bool faces_against_corners(const loop_vertex& a, const loop_vertex& b, const loop_vertex& c) {
  const vec3 face = cross(b.position - a.position, c.position - a.position);
  return dot(face, a.normal) < 0 && dot(face, b.normal) < 0 && dot(face, c.normal) < 0;
}

/// q² of triangle a, b, c (in this order) when it satisfies rules 1 (common wall) 2 and 3 (area), else
/// `infeasible`. Edge lengths are checked by the callers (they are per pair, not per triangle); ab2, bc2, ca2 are
/// the squared edge lengths. Squared so that the bottleneck pass needs no square root (q ↦ q² is monotone).
/// Written so that NaN coordinates fail every test.
inline double evaluate_triangle(const loop_vertex& a, const loop_vertex& b, const loop_vertex& c, double ab2,
                                double bc2, double ca2, const rule_limits& limits) {
  if ((a.planes & b.planes & c.planes) != 0) return infeasible;
  const vec3 face = cross(b.position - a.position, c.position - a.position);
  const double face2 = squared_norm(face);
  const double longest2 = std::max(ab2, std::max(bc2, ca2));
  if (!(face2 >= limits.area_coef * longest2 * longest2) || !(face2 > 0)) return infeasible;
  // Rule 2's floor, whatever its threshold (with rule 2 at its default no fold passes anyway: dot(face, Σn) < 0).
  if (faces_against_corners(a, b, c)) return infeasible;
  if (limits.orientation != rule_limits::rule2::off) {
    // cos(face, Σn) > c, i.e. dot > c·|face|·|Σn|, without square roots.
    const vec3 normals = a.normal + b.normal + c.normal;
    const double agreement = dot(face, normals);
    const double bound2 = limits.cos2 * face2 * squared_norm(normals);
    if (limits.orientation == rule_limits::rule2::non_negative) {
      if (!(agreement > 0) || !(agreement * agreement > bound2)) return infeasible;
    } else if (!(agreement >= 0) && !(agreement * agreement < bound2)) {
      return infeasible;
    }
  }
  if (limits.agreement_objective) {
    const vec3 normals = a.normal + b.normal + c.normal;
    const double cosine = dot(face, normals) / std::sqrt(face2 * squared_norm(normals));
    const double agreement = 0.5 * (1 + std::clamp(cosine, -1.0, 1.0));
    return agreement * agreement;  // squared like q²
  }
  const double shortest2 = std::min(ab2, std::min(bc2, ca2));
  const double sum2 = ab2 + bc2 + ca2;
  // q² = min(edge ratio², mean ratio²); mean ratio = 4√3·area/Σe² = 2√3·|face|/Σe².
  return std::min(shortest2 / longest2, 12 * face2 / (sum2 * sum2));
}

template <class T>
void grow(std::vector<T>& v, std::size_t n) {
  if (v.size() < n) v.resize(n);
}

/// Reusable buffers of the dynamic programmes: O(n²) numbers for a loop of n vertices (≈ 37·n² bytes: 1.5 MB at
/// n = 200), one per thread so that no loop allocates. Their contents between calls are meaningless.
struct workspace {
  std::vector<double> worst;            ///< best worst-quality per sub-polygon (pass 1), mirrored
  std::vector<double> sum;              ///< best quality sum per sub-polygon (pass 2), mirrored
  std::vector<std::uint32_t> split;     ///< chosen apex per sub-polygon / predecessor per band state
  std::vector<double> apex_quality;     ///< q of the chosen apex's triangle per sub-polygon
  std::vector<std::uint8_t> edge_ok;    ///< admissible edge per vertex pair
  std::vector<double> quality;          ///< squared edge lengths (loop); band triangles' q, bridges (annulus)
  std::vector<std::array<std::uint32_t, 2>> stack;
};

workspace& thread_workspace() {
  thread_local workspace buffers;
  return buffers;
}

// ---------------------------------------------------------------------------------------------------------------
// Band of an annulus. P is the longer loop (p vertices, index a), Q the other (q vertices). A band is a closed path
// on the grid a ∈ [0, p], t ∈ [0, q] from (0, 0) to (p, q), monotone in both: grid point (a, t) is the bridge edge
// P[a mod p] — Q[x(t)] with x(t) = (b0 − t) mod q, i.e. Q is walked backwards, since the two loops run in opposite
// senses around the tube. A P-step (a, t) → (a + 1, t) is the triangle (P[a], P[a+1], Q[x(t)]); a Q-step
// (a, t) → (a, t + 1) is (Q[x(t) − 1], Q[x(t)], P[a]); both counter-clockwise seen from outside.
//
// Every band contains, at P[0], a last bridge (in path order) P[0] — Q[b0], followed by a P-step. Starting there,
// the path is a band without a repeated edge exactly when it neither reaches (p, 0) (repeating the bridge
// P[0] — Q[b0]) nor climbs a whole column (a, 0) → (a, q) (repeating P[a] — Q[b0]). The flag f of a state says "no
// P-step since leaving row 0", so (a, q, f = 1) is the forbidden full column; (p, 0) needs no test of its own, as
// the only way on from it is up the whole column p. Trying every b0 covers every band exactly once.
// ---------------------------------------------------------------------------------------------------------------

struct band_problem {
  std::span<const loop_vertex> P, Q;
  std::size_t p = 0, q = 0;
  const std::uint8_t* bridge_ok = nullptr;  ///< [a * q + x]
  const double* step_p = nullptr;           ///< [a * q + x]: q of (P[a], P[a+1], Q[x])
  const double* step_q = nullptr;           ///< [a * q + x]: q of (Q[x−1], Q[x], P[a])
};

enum class band_mode { worst, sum, trace };

/// One band DP for start b0. mode worst: returns the best worst quality, states whose value cannot exceed `bound`
/// are not expanded; mode sum / trace: returns the best Σ q over paths whose triangles all reach `threshold`
/// (−∞ when none), trace also recording predecessors in `pred` (bit 0: arrived by a Q-step; bit 1: source flag).
double band_pass(const band_problem& bp, std::size_t b0, band_mode mode, double bound, double threshold,
                 double* value, std::uint32_t* pred) {
  const std::size_t p = bp.p, q = bp.q, rows = q + 1;
  const auto state = [&](std::size_t a, std::size_t t, std::size_t f) { return (a * rows + t) * 2 + f; };
  const auto x_of = [&](std::size_t t) { return (b0 + q - t % q) % q; };
  const double none = mode == band_mode::worst ? infeasible : -std::numeric_limits<double>::infinity();
  std::fill(value, value + (p + 1) * rows * 2, none);
  if (!bp.bridge_ok[x_of(0)] || !bp.bridge_ok[1 % p * q + x_of(0)]) return none;
  // Forced first P-step (0, 0) → (1, 0, f = 1).
  const double first = bp.step_p[x_of(0)];
  if (mode == band_mode::worst) {
    if (first <= bound) return none;
    value[state(1, 0, 1)] = first;
  } else {
    if (first < threshold) return none;
    value[state(1, 0, 1)] = first;
    if (pred) pred[state(1, 0, 1)] = 0;
  }
  const auto relax = [&](std::size_t target, double from, double tri, std::uint32_t how) {
    if (mode == band_mode::worst) {
      const double v = std::min(from, tri);
      if (v > value[target]) value[target] = v;
    } else {
      if (tri < threshold) return;
      const double v = from + tri;
      if (v > value[target]) {
        value[target] = v;
        if (pred) pred[target] = how;
      }
    }
  };
  for (std::size_t a = 1; a <= p; ++a)
    for (std::size_t t = 0; t <= q; ++t)
      for (std::size_t f = 0; f < 2; ++f) {
        const double from = value[state(a, t, f)];
        if (mode == band_mode::worst ? from <= bound : from == none) continue;
        const std::size_t x = x_of(t), pa = a % p;
        // P-step → (a + 1, t).
        if (a < p && bp.bridge_ok[(a + 1) % p * q + x])
          relax(state(a + 1, t, t == 0 ? 1 : 0), from, bp.step_p[pa * q + x], static_cast<std::uint32_t>(f << 1));
        // Q-step → (a, t + 1); never a whole column (a, q, f = 1).
        if (t < q && !(t + 1 == q && f == 1) && bp.bridge_ok[pa * q + x_of(t + 1)])
          relax(state(a, t + 1, f), from, bp.step_q[pa * q + x], static_cast<std::uint32_t>(1 | f << 1));
      }
  return value[state(p, q, 0)];
}

}  // namespace

double triangle_quality(const vec3& a, const vec3& b, const vec3& c) {
  const double ab2 = squared_norm(b - a), bc2 = squared_norm(c - b), ca2 = squared_norm(a - c);
  const double longest2 = std::max(ab2, std::max(bc2, ca2));
  const double shortest2 = std::min(ab2, std::min(bc2, ca2));
  if (!(shortest2 > 0) || !std::isfinite(longest2)) return 0;
  const double face2 = squared_norm(cross(b - a, c - a));
  const double sum2 = ab2 + bc2 + ca2;
  const double q2 = std::min(shortest2 / longest2, 12 * face2 / (sum2 * sum2));
  return std::isfinite(q2) ? std::sqrt(std::min(q2, 1.0)) : 0;
}

std::optional<double> triangulate_loop(std::span<const loop_vertex> loop,
                                       std::vector<std::array<std::uint32_t, 3>>& out,
                                       const loop_triangulation_settings& settings) {
  const std::size_t n = loop.size();
  if (n < 3) return std::nullopt;
  workspace& ws = thread_workspace();
  const rule_limits limits(settings);
  const std::size_t nn = n * n;
  grow(ws.worst, nn);
  grow(ws.sum, nn);
  grow(ws.split, nn);
  grow(ws.edge_ok, nn);
  grow(ws.quality, nn);  // squared lengths
  grow(ws.apex_quality, nn);
  double* const W = ws.worst.data();
  double* const S = ws.sum.data();
  double* const L2 = ws.quality.data();
  std::uint8_t* const ok = ws.edge_ok.data();

  // Per pair i < j, at [i*n + j]: squared length, and rule 1's edge part with rule 3's length part.
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const double d2 = squared_norm(loop[j].position - loop[i].position);
      const bool consecutive = j == i + 1 || (i == 0 && j == n - 1);
      const bool good = d2 >= limits.min_edge2 && (consecutive || (loop[i].planes & loop[j].planes) == 0);
      L2[i * n + j] = d2;
      ok[i * n + j] = good ? 1 : 0;
    }
  // A loop edge too short for rule 3 belongs to some triangle of every triangulation.
  bool loop_edges_ok = ok[n - 1];
  for (std::size_t i = 0; i + 1 < n; ++i) loop_edges_ok = loop_edges_ok && ok[i * n + i + 1];
  if (!loop_edges_ok) return std::nullopt;

  const auto triangle = [&](std::size_t i, std::size_t k, std::size_t j) {
    return evaluate_triangle(loop[i], loop[k], loop[j], L2[i * n + k], L2[k * n + j], L2[i * n + j], limits);
  };

  // Pass 1: W(i, j) = max over triangulations of the sub-polygon i, i+1, …, j (closed by the chord (i, j)) of the
  // worst q², the chord being admissible. W(k, j) is read from the mirror [j*n + k] so both reads run along rows.
  for (std::size_t i = 0; i + 1 < n; ++i) W[i * n + i + 1] = W[(i + 1) * n + i] = empty_worst;
  const bool long_loop = n > 16;
  for (std::size_t len = 2; len < n; ++len)
    for (std::size_t i = 0, j = len; j < n; ++i, ++j) {
      double best = infeasible;
      if (ok[i * n + j]) {
        const double* wi = W + i * n;
        const double* wj = W + j * n;
        for (std::size_t k = i + 1; k < j; ++k) {
          // Long loops: skip four apexes at a time while none can improve (they spend most of their time here).
          while (long_loop && k + 4 <= j) {
            const double b01 = std::max(std::min(wi[k], wj[k]), std::min(wi[k + 1], wj[k + 1]));
            const double b23 = std::max(std::min(wi[k + 2], wj[k + 2]), std::min(wi[k + 3], wj[k + 3]));
            if (std::max(b01, b23) > best) break;
            k += 4;
          }
          if (k >= j) break;
          const double bound = std::min(wi[k], wj[k]);
          if (bound <= best) continue;  // cannot improve (also skips infeasible sides)
          const double v = std::min(bound, triangle(i, k, j));
          if (v > best) best = v;
        }
      }
      W[i * n + j] = W[j * n + i] = best;
    }
  const double optimum = W[n - 1];  // q*²
  if (!(optimum > 0)) return std::nullopt;

  // Pass 2: S(i, j) = max Σ q over triangulations of the sub-polygon whose triangles all reach q*. W(i, j) ≥ q*²
  // says such a triangulation exists, so only those sub-polygons are visited. Thresholds compare squares.
  const double threshold = optimum * ((1 - tie_tolerance) * (1 - tie_tolerance));
  std::uint32_t* const K = ws.split.data();
  double* const apex_q = ws.apex_quality.data();
  for (std::size_t i = 0; i + 1 < n; ++i) S[i * n + i + 1] = S[(i + 1) * n + i] = 0;
  for (std::size_t len = 2; len < n; ++len)
    for (std::size_t i = 0, j = len; j < n; ++i, ++j) {
      if (!(W[i * n + j] >= threshold)) continue;  // S and K never read there
      double best = -std::numeric_limits<double>::infinity();
      std::uint32_t apex = 0;
      double apex_qk = 0;
      const double* wi = W + i * n;
      const double* wj = W + j * n;
      for (std::size_t k = i + 1; k < j; ++k) {
        if (!(wi[k] >= threshold) || !(wj[k] >= threshold)) continue;
        const double q2 = triangle(i, k, j);
        if (!(q2 >= threshold)) continue;
        const double qk = std::sqrt(q2);
        const double s = qk + S[i * n + k] + S[j * n + k];
        if (s > best) {
          best = s;
          apex = static_cast<std::uint32_t>(k);
          apex_qk = qk;
        }
      }
      S[i * n + j] = S[j * n + i] = best;
      K[i * n + j] = apex;
      apex_q[i * n + j] = apex_qk;
    }

  // Emit (i, k, j), i < k < j: loop order, hence counter-clockwise seen from outside.
  double worst = 1;
  out.reserve(out.size() + n - 2);
  ws.stack.clear();
  ws.stack.push_back({0, static_cast<std::uint32_t>(n - 1)});
  while (!ws.stack.empty()) {
    const auto [i, j] = ws.stack.back();
    ws.stack.pop_back();
    const std::uint32_t k = K[std::size_t{i} * n + j];
    out.push_back({i, k, j});
    const double qk = apex_q[std::size_t{i} * n + j];
    worst = std::min(worst, qk);
    if (j - k >= 2) ws.stack.push_back({k, j});
    if (k - i >= 2) ws.stack.push_back({i, k});
  }
  return worst;
}

std::optional<double> triangulate_annulus(std::span<const loop_vertex> outer, std::span<const loop_vertex> inner,
                                          std::vector<std::array<std::uint32_t, 3>>& out,
                                          const loop_triangulation_settings& settings) {
  if (outer.size() < 3 || inner.size() < 3) return std::nullopt;
  workspace& ws = thread_workspace();
  const bool swapped = inner.size() > outer.size();
  band_problem bp;
  bp.P = swapped ? inner : outer;
  bp.Q = swapped ? outer : inner;
  bp.p = bp.P.size();
  bp.q = bp.Q.size();
  const std::size_t p = bp.p, q = bp.q;
  const rule_limits limits(settings);

  // Loop edges (each belongs to one band triangle) and bridges.
  const auto edge2 = [](const loop_vertex& u, const loop_vertex& v) { return squared_norm(v.position - u.position); };
  for (std::size_t a = 0; a < p; ++a)
    if (!(edge2(bp.P[a], bp.P[(a + 1) % p]) >= limits.min_edge2)) return std::nullopt;
  for (std::size_t x = 0; x < q; ++x)
    if (!(edge2(bp.Q[x], bp.Q[(x + 1) % q]) >= limits.min_edge2)) return std::nullopt;
  grow(ws.edge_ok, p * q);
  grow(ws.quality, 3 * p * q);
  double* const bridge2 = ws.quality.data() + 2 * p * q;
  for (std::size_t a = 0; a < p; ++a)
    for (std::size_t x = 0; x < q; ++x) {
      const double d2 = edge2(bp.P[a], bp.Q[x]);
      bridge2[a * q + x] = d2;
      ws.edge_ok[a * q + x] = d2 >= limits.min_edge2 && (bp.P[a].planes & bp.Q[x].planes) == 0 ? 1 : 0;
    }
  // Every candidate triangle once: 2·p·q.
  double* const step_p = ws.quality.data();
  double* const step_q = ws.quality.data() + p * q;
  for (std::size_t a = 0; a < p; ++a)
    for (std::size_t x = 0; x < q; ++x) {
      const std::size_t a1 = (a + 1) % p, xm = (x + q - 1) % q;
      step_p[a * q + x] = infeasible;
      step_q[a * q + x] = infeasible;
      if (ws.edge_ok[a * q + x] && ws.edge_ok[a1 * q + x]) {
        step_p[a * q + x] = evaluate_triangle(bp.P[a], bp.P[a1], bp.Q[x], edge2(bp.P[a], bp.P[a1]),
                                              bridge2[a1 * q + x], bridge2[a * q + x], limits);
      }
      if (ws.edge_ok[a * q + xm] && ws.edge_ok[a * q + x]) {
        step_q[a * q + x] = evaluate_triangle(bp.Q[xm], bp.Q[x], bp.P[a], edge2(bp.Q[xm], bp.Q[x]),
                                              bridge2[a * q + x], bridge2[a * q + xm], limits);
      }
    }
  for (std::size_t i = 0; i < 2 * p * q; ++i)
    if (step_p[i] >= 0) step_p[i] = std::sqrt(step_p[i]);  // q² → q (step_q follows step_p in the buffer)
  bp.bridge_ok = ws.edge_ok.data();
  bp.step_p = step_p;
  bp.step_q = step_q;

  const std::size_t states = (p + 1) * (q + 1) * 2;
  grow(ws.worst, states);
  grow(ws.split, states);
  // Pass 1: the best worst quality over every start (branch and bound across starts).
  double optimum = infeasible;
  for (std::size_t b0 = 0; b0 < q; ++b0)
    optimum = std::max(optimum, band_pass(bp, b0, band_mode::worst, optimum, 0, ws.worst.data(), nullptr));
  if (!(optimum > 0)) return std::nullopt;
  // Pass 2: the best sum among bands reaching the optimum; then trace the winner.
  const double threshold = optimum * (1 - tie_tolerance);
  double best_sum = -std::numeric_limits<double>::infinity();
  std::size_t best_b0 = 0;
  for (std::size_t b0 = 0; b0 < q; ++b0) {
    const double s = band_pass(bp, b0, band_mode::sum, 0, threshold, ws.worst.data(), nullptr);
    if (s > best_sum) {
      best_sum = s;
      best_b0 = b0;
    }
  }
  band_pass(bp, best_b0, band_mode::trace, 0, threshold, ws.worst.data(), ws.split.data());

  // Walk back from (p, q, 0), emitting triangles in reverse band order.
  const std::size_t rows = q + 1;
  const auto x_of = [&](std::size_t t) { return (best_b0 + q - t % q) % q; };
  const std::uint32_t p_base = swapped ? static_cast<std::uint32_t>(outer.size()) : 0;
  const std::uint32_t q_base = swapped ? 0 : static_cast<std::uint32_t>(outer.size());
  const std::size_t first = out.size();
  out.reserve(first + p + q);
  double worst = 1;
  std::size_t a = p, t = q, f = 0;
  while (!(a == 0 && t == 0)) {
    const std::uint32_t how = (a == 1 && t == 0) ? 0 : ws.split[(a * rows + t) * 2 + f];
    if ((how & 1) == 0) {  // P-step from (a − 1, t)
      --a;
      const std::size_t x = x_of(t);
      out.push_back({p_base + static_cast<std::uint32_t>(a % p), p_base + static_cast<std::uint32_t>((a + 1) % p),
                     q_base + static_cast<std::uint32_t>(x)});
      worst = std::min(worst, step_p[a % p * q + x]);
    } else {  // Q-step from (a, t − 1)
      --t;
      const std::size_t x = x_of(t);
      out.push_back({q_base + static_cast<std::uint32_t>((x + q - 1) % q), q_base + static_cast<std::uint32_t>(x),
                     p_base + static_cast<std::uint32_t>(a % p)});
      worst = std::min(worst, step_q[a % p * q + x]);
    }
    f = how >> 1;
  }
  std::reverse(out.begin() + static_cast<std::ptrdiff_t>(first), out.end());
  return worst;
}

namespace {

struct point2 {
  double u, v;
};

double cross2(const point2& o, const point2& a, const point2& b) {
  return (a.u - o.u) * (b.v - o.v) - (a.v - o.v) * (b.u - o.u);
}

/// Whether the closed segments ab and cd share a point (exact sign tests on the projected coordinates).
bool segments_meet(const point2& a, const point2& b, const point2& c, const point2& d) {
  const double d1 = cross2(c, d, a), d2 = cross2(c, d, b), d3 = cross2(a, b, c), d4 = cross2(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  const auto on_segment = [](const point2& p, const point2& q, const point2& r) {  // r on pq, given collinear
    return std::min(p.u, q.u) <= r.u && r.u <= std::max(p.u, q.u) && std::min(p.v, q.v) <= r.v &&
           r.v <= std::max(p.v, q.v);
  };
  return (d1 == 0 && on_segment(c, d, a)) || (d2 == 0 && on_segment(c, d, b)) || (d3 == 0 && on_segment(a, b, c)) ||
         (d4 == 0 && on_segment(a, b, d));
}

/// Whether the closed polygon is simple: no two edges meet but neighbours at their shared vertex.
bool is_simple(const std::vector<point2>& polygon) {
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const bool neighbours = j == i + 1 || (i == 0 && j == n - 1);
      if (neighbours) continue;
      if (segments_meet(polygon[i], polygon[(i + 1) % n], polygon[j], polygon[(j + 1) % n])) return false;
    }
  }
  return true;
}

/// Whether p lies in the closed triangle abc (counter-clockwise).
bool in_triangle(const point2& p, const point2& a, const point2& b, const point2& c) {
  return cross2(a, b, p) >= 0 && cross2(b, c, p) >= 0 && cross2(c, a, p) >= 0;
}

}  // namespace

bool triangulate_loop_in_its_plane(std::span<const loop_vertex> loop, std::vector<std::array<std::uint32_t, 3>>& out,
                                   const loop_triangulation_settings& settings) {
  const std::size_t n = loop.size();
  if (n < 3) return false;
  // Newell's normal: twice the vector area of the loop.
  vec3 normal;
  for (std::size_t i = 0; i < n; ++i) normal += cross(loop[i].position, loop[(i + 1) % n].position);
  if (!(squared_norm(normal) > 0)) return false;
  normal = normalized(normal);
  const vec3 axis_u = normalized(std::abs(normal.x) < 0.9 ? cross(normal, vec3{1, 0, 0}) : cross(normal, vec3{0, 1, 0}));
  const vec3 axis_v = cross(normal, axis_u);
  std::vector<point2> projected(n);
  for (std::size_t i = 0; i < n; ++i) projected[i] = {dot(loop[i].position, axis_u), dot(loop[i].position, axis_v)};
  if (!is_simple(projected)) return false;
  const double min_edge2 = settings.min_edge_length * settings.min_edge_length;
  std::vector<std::uint32_t> left(n);
  for (std::size_t i = 0; i < n; ++i) left[i] = static_cast<std::uint32_t>(i);
  std::vector<std::array<std::uint32_t, 3>> triangles;
  while (left.size() > 3) {
    const std::size_t m = left.size();
    std::size_t best = m;
    double best_quality = -1;
    for (std::size_t k = 0; k < m; ++k) {
      const std::uint32_t a = left[(k + m - 1) % m], b = left[k], c = left[(k + 1) % m];
      if (!(cross2(projected[a], projected[b], projected[c]) > 0)) continue;  // reflex or flat: not an ear
      bool empty = true;
      for (const std::uint32_t p : left) {
        if (p != a && p != b && p != c && in_triangle(projected[p], projected[a], projected[b], projected[c])) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      // With more than three vertices left, a and c are not neighbours on the loop: (a, c) is a new edge.
      if ((loop[a].planes & loop[c].planes & settings.kept_walls) != 0) continue;
      const vec3 &pa = loop[a].position, &pc = loop[c].position;
      if (!(squared_norm(pc - pa) >= min_edge2)) continue;
      const double longest2 = std::max({squared_norm(loop[b].position - pa), squared_norm(pc - loop[b].position),
                                        squared_norm(pc - pa)});
      if (!(norm(cross(loop[b].position - pa, pc - pa)) >= 2 * settings.min_area_ratio * longest2)) continue;
      if (faces_against_corners(loop[a], loop[b], loop[c])) continue;
      const double q = triangle_quality(pa, loop[b].position, pc);
      if (q > best_quality) {  // ties: the first in loop order, so the result is deterministic
        best_quality = q;
        best = k;
      }
    }
    if (best == m) return false;
    triangles.push_back({left[(best + m - 1) % m], left[best], left[(best + 1) % m]});
    left.erase(left.begin() + static_cast<std::ptrdiff_t>(best));
  }
  const double q = triangle_quality(loop[left[0]].position, loop[left[1]].position, loop[left[2]].position);
  if (!(cross2(projected[left[0]], projected[left[1]], projected[left[2]]) > 0) || !(q > 0) ||
      faces_against_corners(loop[left[0]], loop[left[1]], loop[left[2]])) {
    return false;
  }
  triangles.push_back({left[0], left[1], left[2]});
  // In loop order (i < k < j rotated), like triangulate_loop: each triangle's corners are already in loop order.
  out.insert(out.end(), triangles.begin(), triangles.end());
  return true;
}

}  // namespace tracemesh
