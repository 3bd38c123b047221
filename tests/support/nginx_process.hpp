#pragma once
// nginx in front of tracemeshd replicas for the end-to-end tests: docker/nginx's plain server file and its replicas
// upstream (upstream-replicas.conf) with only the listen address, the replicas' addresses and the file paths made
// local (as tests/image/nginx_check.sh does for one replica), run in the foreground as a child process on a free
// loopback port and stopped (SIGTERM) when the object goes. Tests skip when nginx is not installed.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "support/child_process.hpp"
#include "support/redis_process.hpp"
#include "support/test_http_client.hpp"
#include "support/tracemeshd_process.hpp"

namespace tracemesh::testing {

/// The nginx executable on PATH or in /usr/sbin, or "" when there is none.
inline std::string nginx_binary() {
  for (const char* candidate : {"/usr/sbin/nginx", "/usr/bin/nginx", "/usr/local/sbin/nginx"}) {
    if (::access(candidate, X_OK) == 0) return candidate;
  }
  return "";
}

/// Every occurrence of `from` in `text` replaced by `to`.
inline std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (auto at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

class nginx_process {
 public:
  /// nginx in `dir` proxying to tracemeshd replicas on the loopback `replica_ports` (at most as many as
  /// upstream-replicas.conf names). port() is 0 when it did not start (with a gtest failure).
  nginx_process(const std::filesystem::path& dir, const std::vector<unsigned short>& replica_ports) : dir_(dir) {
    std::filesystem::create_directories(dir_);
    const std::filesystem::path conf = std::filesystem::path(TRACEMESH_SOURCE_DIR) / "docker" / "nginx";
    std::string upstream = read_file(conf / "upstream-replicas.conf");
    for (std::size_t i = 0; i < replica_ports.size(); ++i) {
      upstream = replace_all(upstream, "tracemesh-" + std::to_string(i + 1) + ":8080",
                             "127.0.0.1:" + std::to_string(replica_ports[i]));
    }
    write(dir_ / "upstream.conf", upstream);
    for (int attempt = 0; attempt < 5 && port_ == 0; ++attempt) {
      const unsigned short port = free_loopback_port();
      std::string server = read_file(conf / "tracemesh.conf");
      server = replace_all(server, "listen 80;", "listen 127.0.0.1:" + std::to_string(port) + ";");
      server = replace_all(server, "/etc/nginx/tracemesh/upstream.conf", (dir_ / "upstream.conf").string());
      server = replace_all(server, "/etc/nginx/tracemesh/proxy.conf", (conf / "proxy.conf").string());
      write(dir_ / "server.conf", server);
      write_main_conf();
      if (launch(port)) port_ = port;
    }
    if (port_ == 0) ADD_FAILURE() << "nginx did not start: " << read_file(dir_ / "error.log");
  }
  ~nginx_process() { kill_process(pid_, SIGTERM); }  // TERM: the master stops its workers
  nginx_process(const nginx_process&) = delete;
  nginx_process& operator=(const nginx_process&) = delete;

  unsigned short port() const { return port_; }
  std::string error_log() const { return read_file(dir_ / "error.log"); }

 private:
  static void write(const std::filesystem::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
  }

  void write_main_conf() {
    const std::string d = dir_.string();
    write(dir_ / "nginx.conf",
          std::string(::geteuid() == 0 ? "user root root;\n" : "") + "worker_processes 1;\npid " + d +
              "/nginx.pid;\nerror_log " + d + "/error.log;\nevents { worker_connections 256; }\nhttp {\n  access_log " +
              d + "/access.log;\n  client_body_temp_path " + d + "/body; proxy_temp_path " + d + "/proxy;\n" +
              "  fastcgi_temp_path " + d + "/fastcgi; uwsgi_temp_path " + d + "/uwsgi; scgi_temp_path " + d +
              "/scgi;\n  include " + d + "/server.conf;\n}\n");
  }

  /// Starts nginx and waits until it answers on `port`; false (process reaped) when it exits first.
  bool launch(unsigned short port) {
    const std::string binary = nginx_binary();
    pid_ = spawn_process({binary, "-p", dir_.string(), "-c", (dir_ / "nginx.conf").string(), "-g", "daemon off;"});
    return wait_until_ready(pid_, std::chrono::seconds(120), [&] {
      return raw_connection(port, std::chrono::milliseconds(200)).connected();
    });
  }

  std::filesystem::path dir_;
  pid_t pid_ = -1;
  unsigned short port_ = 0;
};

/// Skips the calling test when nginx is not installed; use as the first line of a test.
#define TRACEMESH_REQUIRE_NGINX()                                                                        \
  do {                                                                                                   \
    if (::tracemesh::testing::nginx_binary().empty())                                                    \
      GTEST_SKIP() << "nginx is not installed (scripts/install-deps.sh installs Debian's nginx-light)";  \
  } while (false)

}  // namespace tracemesh::testing
