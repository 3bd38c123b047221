// tracemesh: the command-line mesher. See cli/options.hpp for the command line, and cli/nanoshaper/ for
// `tracemesh nanoshaper [CONF.prm]` (also run when the program is invoked as NanoShaper).
// Exit codes: 0 success, 1 input or processing error, 2 misuse (bad option or parameter), 130 interrupted.
// Every failure prints exactly one line, "tracemesh: <message>", on stderr.
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli/nanoshaper/nanoshaper_command.hpp"
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

/// Runs `job` with a progress token that SIGINT cancels; the token's listener is `on_progress`.
tracemesh::status run_interruptible(const tracemesh::progress_token::listener& on_progress,
                                    const std::function<tracemesh::status(tracemesh::progress_token&)>& job) {
  tracemesh::progress_token token([&on_progress, &token](tracemesh::mesh_stage stage, double fraction) {
    if (on_progress) on_progress(stage, fraction);
    if (tracemesh::cli::hold_progress_for_tests != nullptr) tracemesh::cli::hold_progress_for_tests(stage, token);
  });
  running_job.store(&token);
  std::signal(SIGINT, cancel_on_interrupt);
  const tracemesh::status outcome = job(token);
  std::signal(SIGINT, SIG_DFL);
  running_job.store(nullptr);
  return outcome;
}

int run_and_report(const tracemesh::cli::cli_options& options) {
  tracemesh::cli::progress_bar bar(stderr, ::isatty(STDERR_FILENO) == 1, options.params.method,
                                   options.params.refine);
  const tracemesh::status outcome =
      run_interruptible([&bar](tracemesh::mesh_stage stage, double fraction) { bar.update(stage, fraction); },
                        [&options](tracemesh::progress_token& token) { return tracemesh::cli::run(options, token); });
  bar.clear();
  if (!outcome) print_error(outcome.message());
  return exit_code_for(outcome.code());
}

/// The NanoShaper front end: every failure, a bad value in the configuration included, exits 1 (NanoShaper's
/// callers tell only success from failure), except an interruption.
int run_nanoshaper(const std::vector<std::string_view>& arguments) {
  namespace ns = tracemesh::cli::nanoshaper;
  const ns::nanoshaper_command_line parsed = ns::parse_nanoshaper_command_line(arguments);
  if (!parsed.configuration) {
    std::fputs(parsed.standard_output.c_str(), stdout);
    if (!parsed.error.empty()) print_error(parsed.error);
    return parsed.exit_code;
  }
  const tracemesh::status outcome = run_interruptible({}, [&parsed](tracemesh::progress_token& token) {
    return ns::run_nanoshaper(*parsed.configuration, token, stderr, stdout);
  });
  if (!outcome) print_error(outcome.message());
  return outcome.code() == tracemesh::errc::cancelled ? exit_interrupted : outcome ? 0 : exit_input_error;
}

/// The arguments of the NanoShaper front end, or nullopt when the command line is tracemesh's own.
std::optional<std::vector<std::string_view>> nanoshaper_arguments(int argc, char** argv) {
  if (argc >= 1 && tracemesh::cli::nanoshaper::invoked_as_nanoshaper(argv[0])) {
    return std::vector<std::string_view>(argv + 1, argv + argc);
  }
  if (argc >= 2 && std::string_view(argv[1]) == "nanoshaper") {
    return std::vector<std::string_view>(argv + 2, argv + argc);
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  const tracemesh::tbb_under_thread_sanitizer tbb_checkable;  // ThreadSanitizer builds only
  if (const auto arguments = nanoshaper_arguments(argc, argv)) {
    try {
      return run_nanoshaper(*arguments);
    } catch (const std::exception& error) {
      print_error(std::string("internal error: ") + error.what());
      return exit_input_error;
    }
  }
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
