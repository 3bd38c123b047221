#pragma once
// The environment through which an end-to-end test holds jobs in tracemeshd_testable (tests/CMakeLists.txt): the
// test program tracemeshd with tests/support/held_mesher_hook.cpp. A held job is running (its worker is taken, it
// can be cancelled, time out or be stopped by a shutdown) but does not mesh until the test creates the gate file,
// so a test that acts on a running job never races the mesher, however fast the machine.
#include <cstddef>
#include <filesystem>
#include <string>

namespace tracemesh::testing {

/// The gate file: jobs wait while it does not exist.
inline constexpr const char* held_jobs_gate_variable = "TRACEMESH_TEST_HOLD_GATE";
/// Only jobs of at least this many atoms are held (unset: every job).
inline constexpr const char* held_jobs_min_atoms_variable = "TRACEMESH_TEST_HOLD_MIN_ATOMS";

/// For tracemesh_testable (the command with tests/support/held_run_hook.cpp): the name of the stage
/// (core/progress.cpp's stage_name) at whose first progress report the run waits until it is interrupted.
inline constexpr const char* held_run_stage_variable = "TRACEMESH_TEST_HOLD_STAGE";

/// Which jobs tracemeshd_testable holds and until when.
struct held_jobs {
  std::filesystem::path gate;  ///< created by the test to let the held jobs mesh
  std::size_t min_atoms = 0;   ///< smaller jobs are not held
};

}  // namespace tracemesh::testing
