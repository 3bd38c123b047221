#pragma once
// Child processes of the end-to-end tests (redis-server, nginx): started with fork + execv, waited for until they
// answer, killed and reaped.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace tracemesh::testing {

/// Forks and runs arguments[0] with `arguments`; the child's pid, or -1 when fork failed.
inline pid_t spawn_process(std::vector<std::string> arguments) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (std::string& argument : arguments) argv.push_back(argument.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

/// SIGKILL and reap; `pid` becomes -1. No-op for pid <= 0.
inline void kill_process(pid_t& pid, int signal = SIGKILL) {
  if (pid <= 0) return;
  ::kill(pid, signal);
  int ignored = 0;
  ::waitpid(pid, &ignored, 0);
  pid = -1;
}

/// Polls `ready()` every 20 ms for up to `within`: true once it holds; false when the process exited first (`pid`
/// reaped, -1) or the time ran out (then the process is killed).
template <typename Ready>
bool wait_until_ready(pid_t& pid, std::chrono::milliseconds within, Ready ready) {
  if (pid <= 0) return false;
  const auto deadline = std::chrono::steady_clock::now() + within;
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      pid = -1;
      return false;
    }
    if (ready()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill_process(pid);
  return false;
}

}  // namespace tracemesh::testing
