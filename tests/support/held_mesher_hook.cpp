// The hook of tracemeshd_testable (tests/CMakeLists.txt): server/service.hpp's wrap_mesher_for_tests, which holds
// the jobs that tests/support/held_jobs.hpp's environment names until their gate file exists. Linked into that test
// program only: the production tracemeshd leaves the weak symbol undefined, so nothing reaches this code there.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>

#include "server/service.hpp"
#include "support/held_jobs.hpp"

namespace tracemesh::server {

namespace {

/// The jobs held, from the environment; nullopt when no gate is named (then nothing is held).
std::optional<testing::held_jobs> held_jobs_from_environment() {
  const char* gate = std::getenv(testing::held_jobs_gate_variable);
  if (gate == nullptr || *gate == '\0') return std::nullopt;
  testing::held_jobs held{gate, 0};
  if (const char* min_atoms = std::getenv(testing::held_jobs_min_atoms_variable)) {
    held.min_atoms = std::strtoull(min_atoms, nullptr, 10);
  }
  return held;
}

/// Waits until the gate exists or the job is cancelled (by DELETE, its deadline or the shutdown); false when
/// cancelled. The pause is the polling interval of a wait on an event (the gate), not a wait for time to pass.
bool wait_for_gate(const std::filesystem::path& gate, const progress_token& token) {
  for (;;) {
    if (token.cancelled()) return false;
    std::error_code ignored;
    if (std::filesystem::exists(gate, ignored)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

}  // namespace

mesher_function wrap_mesher_for_tests(mesher_function mesher) {
  const std::optional<testing::held_jobs> held = held_jobs_from_environment();
  if (!held) return mesher;
  return [mesher = std::move(mesher), held = *held](const molecule& mol, const mesh_params& params,
                                                      const mesh_limits& limits,
                                                      progress_token& token) -> result<mesh_output> {
    if (mol.atoms.size() >= held.min_atoms && !wait_for_gate(held.gate, token)) {
      return status(errc::cancelled, "meshing was cancelled");
    }
    return mesher(mol, params, limits, token);
  };
}

}  // namespace tracemesh::server
