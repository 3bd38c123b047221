#pragma once
// tracemeshd as a child process for the end-to-end tests (tests/integration): started on an ephemeral loopback port
// (read from its "started" log line), its log in a file, killed (SIGKILL) when the object goes; and a temporary
// directory removed at the end of the test.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/eventually.hpp"
#include "support/held_jobs.hpp"
#include "support/test_paths.hpp"

namespace tracemesh::testing {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

inline std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// A temporary directory removed at the end of the test.
class temp_dir {
 public:
  temp_dir() {
    std::string pattern = (fs::temp_directory_path() / "tracemeshd-test-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~temp_dir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// Creates the gate file of `held`: the jobs it holds mesh from now on.
inline void open_gate(const held_jobs& held) { std::ofstream(held.gate) << "open\n"; }

/// tracemeshd as a child process on an ephemeral loopback port; killed on destruction. With `held`, the process is
/// tracemeshd_testable holding those jobs (support/held_jobs.hpp) until open_gate(); else the production tracemeshd.
class server_process {
 public:
  server_process(const fs::path& work, std::vector<std::string> args, std::optional<held_jobs> held = std::nullopt)
      : log_(work / "server.log") {
    // Tests that give no --cache-dir run without a disk store, which tracemeshd requires to be asked for.
    if (std::find(args.begin(), args.end(), "--cache-dir") == args.end() &&
        std::find(args.begin(), args.end(), "--no-disk-store") == args.end()) {
      args.push_back("--no-disk-store");
    }
    const char* program = held ? "tracemeshd_testable" : "tracemeshd";
    args.insert(args.begin(), {binary_path(program).string(), "--listen", "127.0.0.1:0"});
    std::error_code ignored;
    fs::remove(log_, ignored);  // the port is read from this run's "started" line
    pid_ = ::fork();
    if (pid_ == 0) {
      const int log_fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      ::dup2(log_fd, STDERR_FILENO);
      ::dup2(log_fd, STDOUT_FILENO);
      if (held) {
        ::setenv(held_jobs_gate_variable, held->gate.c_str(), 1);
        ::setenv(held_jobs_min_atoms_variable, std::to_string(held->min_atoms).c_str(), 1);
      }
      std::vector<char*> argv;
      for (auto& arg : args) argv.push_back(arg.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    port_ = wait_for_port();
  }
  ~server_process() { kill(SIGKILL); }

  unsigned short port() const { return port_; }
  std::string url(const std::string& path) const { return "http://127.0.0.1:" + std::to_string(port_) + path; }
  std::string log() const { return read_file(log_); }

  /// Sends `signal` and reaps the process; returns its exit status (-1 when killed by a signal or already gone).
  int kill(int signal) {
    send(signal);
    return wait_exit();
  }

  /// Sends `signal` without waiting for the process (wait_exit() reaps it).
  void send(int signal) {
    if (pid_ > 0) ::kill(pid_, signal);
  }

  /// Waits for the process to exit by itself and reaps it; its exit status (-1 when killed by a signal or already
  /// gone).
  int wait_exit() {
    if (pid_ <= 0) return -1;
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  /// The port of the "started" log line. Waits as long as the process runs (a loaded machine or a sanitizer build
  /// starts it slowly); eventually()'s deadline only bounds a server that never starts.
  unsigned short wait_for_port() {
    unsigned short port = 0;
    bool exited = false;
    eventually([&] {
      std::istringstream lines(read_file(log_));
      std::string line;
      while (std::getline(lines, line)) {
        if (line.find("\"event\":\"started\"") == std::string::npos) continue;
        port = nlohmann::json::parse(line).at("port").get<unsigned short>();
        return true;
      }
      int status = 0;
      exited = ::waitpid(pid_, &status, WNOHANG) == pid_;
      if (exited) pid_ = -1;
      return exited;
    });
    if (port == 0) {
      ADD_FAILURE() << "tracemeshd did not start" << (exited ? " (it exited)" : "") << ": " << read_file(log_);
    }
    return port;
  }

  fs::path log_;
  pid_t pid_ = -1;
  unsigned short port_ = 0;
};

}  // namespace tracemesh::testing
