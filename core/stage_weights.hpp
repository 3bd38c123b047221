#pragma once
/// @file stage_weights.hpp
/// Overall progress of a mesher run, proportional to expected time: each stage's share of the run's wall time, per
/// path (lattice, trace raw, trace refined), measured over the molecule ladder (bench/stage_weights.py). The CLI's
/// progress bar and the service's job `progress` both use overall_progress().

#include <array>
#include <cstddef>

#include "core/mesher.hpp"
#include "core/progress.hpp"

namespace tracemesh {

/// Number of stages before mesh_stage::done.
inline constexpr std::size_t progress_stage_count = static_cast<std::size_t>(mesh_stage::done);

/// Share of a run's wall time per stage, indexed by mesh_stage (reading … encoding); non-negative, sums to 1.
using stage_shares = std::array<double, progress_stage_count>;

/// The shares of the path (method, refine). A stage the path does not run has share 0.
const stage_shares& stage_weights(mesh_method method, refine_mode refine) noexcept;

/// Overall progress in [0, 1] of a run of the path (method, refine) that is `fraction` (clamped to [0, 1]; NaN
/// counts as 0) through `stage`: the shares of the stages before it plus `fraction` of its own. Non-decreasing in
/// (stage order, fraction); 1 at mesh_stage::done.
double overall_progress(mesh_method method, refine_mode refine, mesh_stage stage, double fraction) noexcept;

}  // namespace tracemesh
