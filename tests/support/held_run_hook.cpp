// The hook of tracemesh_testable (tests/CMakeLists.txt): cli/run.hpp's hold_progress_for_tests, which holds a run
// at the first progress report of the stage that support/held_jobs.hpp's variable names until the run is
// cancelled (SIGINT). Linked into that test program only: the production tracemesh leaves the weak symbol
// undefined, so nothing reaches this code there.
#include <chrono>
#include <cstdlib>
#include <string_view>
#include <thread>

#include "cli/run.hpp"
#include "support/held_jobs.hpp"

namespace tracemesh::cli {

void hold_progress_for_tests(mesh_stage stage, const progress_token& token) {
  const char* held_stage = std::getenv(testing::held_run_stage_variable);
  if (held_stage == nullptr || std::string_view(held_stage) != stage_name(stage)) return;
  // The pause is the polling interval of a wait on an event (the interrupt), not a wait for time to pass.
  while (!token.cancelled()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
}

}  // namespace tracemesh::cli
