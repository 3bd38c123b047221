#pragma once
// A program run with its stderr on a pseudo-terminal, as a user at a terminal runs it: what it draws only on a
// terminal (tracemesh's progress line) is seen by the test as it happens, so the test can act on an event of the
// run (signal it once it shows it is meshing) instead of after a guessed delay.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

namespace tracemesh::testing {

class terminal_child {
 public:
  /// Starts `program` with `args`, stdin and stdout on /dev/null, stderr on the slave side of a new pseudo-terminal
  /// in raw mode (bytes arrive as written: no "\n" → "\r\n"), and this process's environment plus `environment`
  /// ("NAME=value" each). started() is false when any step failed.
  terminal_child(const std::filesystem::path& program, const std::vector<std::string>& args,
                 std::vector<std::string> environment = {}) {
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) return;
    const char* slave_name = ::ptsname(master_);
    if (slave_name == nullptr) return;
    const std::string slave_path = slave_name;
    std::vector<std::string> argv_text{program.string()};
    argv_text.insert(argv_text.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& arg : argv_text) argv.push_back(arg.data());
    argv.push_back(nullptr);
    std::vector<char*> envp;
    for (char** inherited = environ; *inherited != nullptr; ++inherited) envp.push_back(*inherited);
    for (std::string& added : environment) envp.push_back(added.data());
    envp.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) exec_child(slave_path, argv, envp);
  }
  ~terminal_child() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (master_ >= 0) ::close(master_);
  }
  terminal_child(const terminal_child&) = delete;
  terminal_child& operator=(const terminal_child&) = delete;

  bool started() const { return pid_ > 0; }

  /// Reads the terminal until what the program wrote so far contains `text` (true), or it closed its side or
  /// `within` passed (false). The deadline only bounds how long a failing test takes.
  bool wait_for(const std::string& text, std::chrono::milliseconds within = std::chrono::seconds(120)) {
    const auto deadline = std::chrono::steady_clock::now() + within;
    while (output_.find(text) == std::string::npos) {
      if (std::chrono::steady_clock::now() >= deadline || read_some(100) == read_outcome::closed) return false;
    }
    return true;
  }

  void signal(int number) { ::kill(pid_, number); }

  /// Reads the terminal to its end and waits for the program: its exit code (128 + signal when a signal ended it).
  int wait_exit() {
    while (read_some(-1) != read_outcome::closed) {
    }
    int raw = 0;
    ::waitpid(pid_, &raw, 0);
    exited_ = true;
    return WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
  }

  /// Everything the program wrote on stderr so far.
  const std::string& output() const { return output_; }

 private:
  [[noreturn]] static void exec_child(const std::string& slave_path, std::vector<char*>& argv,
                                      std::vector<char*>& envp) {
    const int slave = ::open(slave_path.c_str(), O_RDWR);
    const int null = ::open("/dev/null", O_RDWR);
    termios raw{};
    if (slave < 0 || null < 0 || ::tcgetattr(slave, &raw) != 0) ::_exit(127);
    ::cfmakeraw(&raw);
    ::tcsetattr(slave, TCSANOW, &raw);
    ::dup2(null, STDIN_FILENO);
    ::dup2(null, STDOUT_FILENO);
    ::dup2(slave, STDERR_FILENO);
    ::execve(argv[0], argv.data(), envp.data());
    ::_exit(127);
  }

  enum class read_outcome { data, nothing, closed };

  /// Appends what the terminal has within `timeout_ms` (-1: until something comes). closed: at its end (the
  /// program closed its side; Linux then reports EIO).
  read_outcome read_some(int timeout_ms) {
    pollfd p{master_, POLLIN, 0};
    const int ready = ::poll(&p, 1, timeout_ms);
    if (ready == 0) return read_outcome::nothing;
    if (ready < 0) return errno == EINTR ? read_outcome::nothing : read_outcome::closed;
    char bytes[4096];
    const ssize_t n = ::read(master_, bytes, sizeof bytes);
    if (n <= 0) return read_outcome::closed;
    output_.append(bytes, static_cast<std::size_t>(n));
    return read_outcome::data;
  }

  int master_ = -1;
  pid_t pid_ = -1;
  bool exited_ = false;
  std::string output_;
};

}  // namespace tracemesh::testing
