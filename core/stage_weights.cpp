#include "core/stage_weights.hpp"

#include <algorithm>
#include <cmath>

namespace tracemesh {
namespace {

constexpr std::size_t index_of(mesh_stage stage) { return static_cast<std::size_t>(stage); }

/// Builds shares from per-stage weights in any unit (they are normalised to sum 1).
constexpr stage_shares normalised(stage_shares weights) {
  double total = 0;
  for (const double w : weights) total += w;
  for (double& w : weights) w /= total;
  return weights;
}

/// The same shares without the quality pass (refine=none), renormalised.
constexpr stage_shares without_refining(stage_shares shares) {
  shares[index_of(mesh_stage::refining)] = 0;
  return normalised(shares);
}

// WEIGHTS-BEGIN (bench/stage_weights.py prints this block)
// Measured 2026-11-25 at 9892ac0 on the 2-core machine (loaded: shares, not seconds, are what matter here):
//   RUNS=1 MAX_ATOMS=17214 bench/run_ladder.sh && python3 bench/stage_weights.py build/bench/ladder.jsonl
// Stage seconds summed over the ladder gly … 3j6r_asu at densities 1 and 2 (14 rows per path), as shares:
//   path             reading culling sampling roots tracing triang. refining certifying encoding
//   lattice refined   0.003   0.003   0.115   0.007   —      0.017   0.753    0.081      0.020
//   trace raw         0.007   0.006    —      0.140  0.446   0.220    —       0.162      0.020
//   trace refined     0.003   0.005    —      0.112  0.256   0.124   0.406    0.074      0.020
// Per row the big shares vary by about ±0.1 (lattice refining 0.64–0.80, trace tracing 0.40–0.65). The last stage
// (the service storing the result, the CLI writing it) is not timed by the ladder: it gets 2% of the measured time.
// Lattice without the quality pass (not in the ladder) is lattice refined without refining, renormalised.
constexpr stage_shares lattice_refined_weights = {
    0.0027, 0.0034, 0.1154, 0.0072, 0.0000, 0.0174, 0.7530, 0.0814, 0.0196};
constexpr stage_shares trace_raw_weights = {
    0.0066, 0.0058, 0.0000, 0.1399, 0.4459, 0.2198, 0.0000, 0.1624, 0.0196};
constexpr stage_shares trace_refined_weights = {
    0.0028, 0.0053, 0.0000, 0.1118, 0.2560, 0.1243, 0.4057, 0.0745, 0.0196};
// WEIGHTS-END

}  // namespace

const stage_shares& stage_weights(mesh_method method, refine_mode refine) noexcept {
  static constexpr stage_shares lattice_refined = normalised(lattice_refined_weights);
  static constexpr stage_shares lattice_raw = without_refining(lattice_refined_weights);
  static constexpr stage_shares trace_refined = normalised(trace_refined_weights);
  static constexpr stage_shares trace_raw = normalised(trace_raw_weights);
  if (method == mesh_method::trace) return refine == refine_mode::full ? trace_refined : trace_raw;
  return refine == refine_mode::full ? lattice_refined : lattice_raw;
}

double overall_progress(mesh_method method, refine_mode refine, mesh_stage stage, double fraction) noexcept {
  if (stage == mesh_stage::done) return 1.0;
  const stage_shares& shares = stage_weights(method, refine);
  const std::size_t at = std::min(index_of(stage), progress_stage_count - 1);
  double before = 0;
  for (std::size_t s = 0; s < at; ++s) before += shares[s];
  const double within = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  return std::min(1.0, before + within * shares[at]);
}

}  // namespace tracemesh
