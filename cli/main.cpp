// tracemesh: the command-line mesher. See cli/options.hpp for the command line.
// Exit codes: 0 success, 1 input or processing error, 2 misuse (bad option or parameter), 130 interrupted.
// Every failure prints exactly one line, "tracemesh: <message>", on stderr.
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <string>

#include "cli/options.hpp"
#include "cli/progress_bar.hpp"
#include "cli/run.hpp"
#include "core/tbb_under_thread_sanitizer.hpp"

namespace {

constexpr int exit_input_error = 1;
constexpr int exit_usage = 2;
constexpr int exit_interrupted = 130;

// The token of the running job, for the SIGINT handler: cancel() is a lock-free atomic store, safe in a handler.
std::atomic<tracemesh::progress_token*> running_job{nullptr};

extern "C" void cancel_on_interrupt(int) {
  if (tracemesh::progress_token* token = running_job.load()) token->cancel();
}

/// The message on one printable line: control characters (a newline in a file name...) become spaces.
std::string one_line(std::string message) {
  for (char& c : message) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  }
  return message;
}

void print_error(const std::string& message) { std::fprintf(stderr, "tracemesh: %s\n", one_line(message).c_str()); }

int exit_code_for(tracemesh::errc code) {
  switch (code) {
    case tracemesh::errc::ok: return 0;
    case tracemesh::errc::invalid_argument: return exit_usage;
    case tracemesh::errc::cancelled: return exit_interrupted;
    default: return exit_input_error;
  }
}

int run_and_report(const tracemesh::cli::cli_options& options) {
  tracemesh::cli::progress_bar bar(stderr, ::isatty(STDERR_FILENO) == 1, options.params.method,
                                   options.params.refine);
  tracemesh::progress_token token([&bar](tracemesh::mesh_stage stage, double fraction) { bar.update(stage, fraction); });
  running_job.store(&token);
  std::signal(SIGINT, cancel_on_interrupt);
  const tracemesh::status outcome = tracemesh::cli::run(options, token);
  std::signal(SIGINT, SIG_DFL);
  running_job.store(nullptr);
  bar.clear();
  if (!outcome) print_error(outcome.message());
  return exit_code_for(outcome.code());
}

}  // namespace

int main(int argc, char** argv) {
  const tracemesh::tbb_under_thread_sanitizer tbb_checkable;  // ThreadSanitizer builds only
  const tracemesh::cli::parsed_command_line parsed = tracemesh::cli::parse_command_line(argc, argv);
  if (!parsed.options) {
    std::fputs(parsed.standard_output.c_str(), stdout);
    if (!parsed.error.empty()) print_error(parsed.error);
    return parsed.exit_code;
  }
  try {
    return run_and_report(*parsed.options);
  } catch (const std::exception& error) {  // out of memory, or a bug: still one line and a clean exit code
    print_error(std::string("internal error: ") + error.what());
    return exit_input_error;
  }
}
