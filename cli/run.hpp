#pragma once
/// @file run.hpp
/// One `tracemesh` run: read the PQR file, mesh it, encode the mesh, write it (and the report) atomically.

#include "cli/options.hpp"
#include "core/progress.hpp"
#include "core/status.hpp"

namespace tracemesh::cli {

/// Runs `options`. Progress goes to `progress` (whose listener may draw a progress bar; cancel() stops the run
/// with errc::cancelled). With options.verbose, timings and a summary are printed on stderr.
/// Errors: those of read_pqr_file, mesh_molecule and the encoders, and errc::io_error when an output cannot be
/// written. Nothing is written unless meshing and encoding succeeded.
status run(const cli_options& options, progress_token& progress);

/// A seam for the test program tracemesh_testable only (tests/CMakeLists.txt, tests/support/held_run_hook.cpp):
/// called after each progress report with the run's token, it may hold the run there until the token is cancelled,
/// so that a test of the interrupt acts on a run that is certainly still meshing, however fast the machine. Weak and
/// left undefined in the production tracemesh, which therefore never calls it.
[[gnu::weak]] void hold_progress_for_tests(mesh_stage stage, const progress_token& token);

}  // namespace tracemesh::cli
