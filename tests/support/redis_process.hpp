#pragma once
// A real redis-server for the tests: started on a free loopback port in its own temporary directory, without
// persistence (--save '' --appendonly no) or, when made `persistent`, with the append-only file fsync'd on every
// write (as docker/compose.yaml runs it), stopped (SIGKILL, as a crash would) and restarted on the same port on
// demand (a persistent one comes back with everything it acknowledged). Tests skip with GTEST_SKIP only when no redis-server is installed (scripts/install-deps.sh installs it).
#include <gtest/gtest.h>

#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "server/redis/redis_client.hpp"
#include "support/child_process.hpp"

namespace tracemesh::testing {

/// The redis-server CMake found (TRACEMESH_REDIS_SERVER), or "" when there is none.
inline std::string redis_server_binary() {
  const std::string path = TRACEMESH_REDIS_SERVER;
  if (path.empty() || path.find("NOTFOUND") != std::string::npos || ::access(path.c_str(), X_OK) != 0) return "";
  return path;
}

/// A loopback TCP port nobody listened on a moment ago (the kernel's choice for port 0).
inline unsigned short free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  unsigned short port = 0;
  if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0) {
    port = ntohs(address.sin_port);
  }
  if (fd >= 0) ::close(fd);
  return port;
}

class redis_process {
 public:
  explicit redis_process(bool persistent = false) : persistent_(persistent) {
    char pattern[] = "/tmp/tracemesh-redis-XXXXXX";
    if (::mkdtemp(pattern) != nullptr) directory_ = pattern;
  }
  ~redis_process() {
    stop();
    std::error_code ignored;
    if (!directory_.empty()) std::filesystem::remove_all(directory_, ignored);
  }
  redis_process(const redis_process&) = delete;
  redis_process& operator=(const redis_process&) = delete;

  /// Starts redis-server on a free port and waits until it answers PING. False (with a gtest failure) if it
  /// could not be started after a few ports.
  bool start() {
    for (int attempt = 0; attempt < 5; ++attempt) {
      port_ = free_loopback_port();
      if (port_ != 0 && launch()) return true;
    }
    ADD_FAILURE() << "redis-server did not start; see " << (directory_ / "redis.log");
    return false;
  }
  /// Kills redis-server (SIGKILL: nothing is flushed, like a crash) and waits for it to exit.
  void stop() { kill_process(pid_); }
  /// A new redis-server on the same port and directory (empty unless persistent).
  bool restart() {
    stop();
    if (launch()) return true;
    ADD_FAILURE() << "redis-server did not restart on port " << port_;
    return false;
  }

  unsigned short port() const { return port_; }
  server::redis_endpoint endpoint(unsigned db = 0) const { return {"127.0.0.1", port_, db}; }
  std::string url(unsigned db = 0) const { return endpoint(db).to_url(); }

 private:
  bool launch() {
    const std::string binary = redis_server_binary();
    const std::string port = std::to_string(port_);
    const std::string log = (directory_ / "redis.log").string();
    std::vector<std::string> arguments{binary,      "--port", port,        "--bind",       "127.0.0.1", "--save",
                                       "",          "--appendonly", persistent_ ? "yes" : "no",
                                       "--appendfsync", "always",   "--dir",        directory_.string(),
                                       "--logfile", log,      "--daemonize", "no"};
    pid_ = spawn_process(arguments);
    // Ready when it answers PING; gone (port taken, bad option) when the child has exited.
    server::redis_limits limits;
    limits.connect_timeout = std::chrono::milliseconds(500);
    server::redis_client probe(endpoint(), limits);
    return wait_until_ready(pid_, std::chrono::seconds(120), [&] { return probe.connect().ok(); });
  }

  const bool persistent_;
  std::filesystem::path directory_;
  unsigned short port_ = 0;
  pid_t pid_ = -1;
};

/// Skips the calling test when no redis-server is installed; use as the first line of a test or SetUp().
#define TRACEMESH_REQUIRE_REDIS_SERVER()                                                                 \
  do {                                                                                                   \
    if (::tracemesh::testing::redis_server_binary().empty())                                             \
      GTEST_SKIP() << "redis-server is not installed (scripts/install-deps.sh installs Debian's)";       \
  } while (false)

}  // namespace tracemesh::testing
