#pragma once
// A deliberately small HTTP/1.1 client over POSIX sockets for the service tests (tests/server, tests/integration):
// it sends exactly the bytes it is given (so tests can send malformed, slow, pipelined or chunked requests) and
// parses one response at a time.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

namespace tracemesh::testing {

struct http_reply {
  int status = 0;  ///< 0 when no complete response arrived
  std::map<std::string, std::string> headers;  ///< lower-case names
  std::string body;
  std::string header(const std::string& name) const {
    const auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  }
};

class raw_connection {
 public:
  /// Connects to 127.0.0.1:`port`. `timeout`: how long each read waits. `receive_buffer_bytes` > 0 shrinks the
  /// socket's receive buffer (set before connecting), so that a client that does not read stalls the server soon.
  explicit raw_connection(unsigned short port, std::chrono::milliseconds timeout = std::chrono::seconds(20),
                          int receive_buffer_bytes = 0, std::uint32_t source_address = INADDR_LOOPBACK)
      : timeout_(timeout) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (receive_buffer_bytes > 0) {
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof receive_buffer_bytes);
    }
    if (source_address != INADDR_LOOPBACK) {  // another client: 127.0.0.0/8 is all loopback on Linux
      sockaddr_in source{};
      source.sin_family = AF_INET;
      source.sin_addr.s_addr = htonl(source_address);
      ::bind(fd_, reinterpret_cast<sockaddr*>(&source), sizeof source);
    }
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  ~raw_connection() {
    if (fd_ >= 0) ::close(fd_);
  }
  raw_connection(const raw_connection&) = delete;
  raw_connection& operator=(const raw_connection&) = delete;

  bool connected() const { return connected_; }

  /// Closes the connection now (a client that goes away mid-request); with `reset`, with a TCP RST.
  void close(bool reset = false) {
    if (fd_ < 0) return;
    if (reset) {
      const linger abort_on_close{1, 0};
      ::setsockopt(fd_, SOL_SOCKET, SO_LINGER, &abort_on_close, sizeof abort_on_close);
    }
    ::close(fd_);
    fd_ = -1;
  }

  /// Bytes received but not yet consumed by read_reply() (e.g. gathered by closed_by_peer()).
  const std::string& unread() const { return buffer_; }

  /// Sends all bytes; false when the peer closed or reset the connection.
  bool send(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t sent = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (sent <= 0) return false;
      bytes.remove_prefix(static_cast<std::size_t>(sent));
    }
    return true;
  }

  /// Sends `bytes` in pieces of `chunk` bytes with a pause between them (exercises incremental parsing).
  bool send_in_chunks(std::string_view bytes, std::size_t chunk, std::chrono::microseconds pause) {
    while (!bytes.empty()) {
      const std::size_t n = std::min(chunk, bytes.size());
      if (!send(bytes.substr(0, n))) return false;
      bytes.remove_prefix(n);
      if (pause.count() > 0) std::this_thread::sleep_for(pause);
    }
    return true;
  }

  /// Reads one response (Content-Length, chunked, or until close). status 0 if none arrived in time.
  http_reply read_reply(bool head_request = false) {
    http_reply reply;
    std::size_t header_end;
    while ((header_end = buffer_.find("\r\n\r\n")) == std::string::npos) {
      if (!fill()) return reply;
    }
    const std::string head = buffer_.substr(0, header_end);
    buffer_.erase(0, header_end + 4);
    std::size_t line_end = head.find("\r\n");
    const std::string status_line = head.substr(0, line_end);
    if (status_line.size() < 12) return reply;
    reply.status = std::stoi(status_line.substr(9, 3));
    while (line_end != std::string::npos) {
      const std::size_t next = head.find("\r\n", line_end + 2);
      const std::string line = head.substr(line_end + 2, next == std::string::npos ? std::string::npos
                                                                                  : next - line_end - 2);
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        std::string name = line.substr(0, colon);
        std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
        std::string value = line.substr(colon + 1);
        value.erase(0, value.find_first_not_of(' '));
        reply.headers[name] = value;
      }
      line_end = next;
    }
    if (head_request || reply.status == 100 || reply.status == 204 || reply.status == 304) return reply;
    if (reply.headers.count("content-length")) {
      const std::size_t length = std::stoull(reply.headers["content-length"]);
      while (buffer_.size() < length) {
        if (!fill()) {
          reply.status = 0;
          return reply;
        }
      }
      reply.body = buffer_.substr(0, length);
      buffer_.erase(0, length);
    } else {
      while (fill()) {
      }
      reply.body = std::move(buffer_);
      buffer_.clear();
    }
    return reply;
  }

  /// True when the server closes the connection (EOF or reset) within `within`. The default only bounds how long a
  /// failing test takes (a closing that must come comes however loaded the machine); a test that checks the
  /// connection stays open passes a short window.
  bool closed_by_peer(std::chrono::milliseconds within = std::chrono::seconds(120)) {
    const auto deadline = std::chrono::steady_clock::now() + within;
    while (std::chrono::steady_clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) > 0) {
        char byte[4096];
        const ssize_t n = ::recv(fd_, byte, sizeof byte, 0);
        if (n <= 0) return true;
        buffer_.append(byte, static_cast<std::size_t>(n));
      }
    }
    return false;
  }

 private:
  bool fill() {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout_.count())) <= 0) return false;
    char bytes[65536];
    const ssize_t n = ::recv(fd_, bytes, sizeof bytes, 0);
    if (n <= 0) return false;
    buffer_.append(bytes, static_cast<std::size_t>(n));
    return true;
  }

  int fd_ = -1;
  bool connected_ = false;
  std::chrono::milliseconds timeout_;
  std::string buffer_;
};

/// A multipart/form-data body: the PQR under "pqr" (with a filename) and the given fields.
inline std::string multipart_body(const std::string& boundary, const std::string& pqr,
                                  const std::vector<std::pair<std::string, std::string>>& fields = {}) {
  std::string body;
  for (const auto& [name, value] : fields) {
    body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + name + "\"\r\n\r\n" + value + "\r\n";
  }
  body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"pqr\"; filename=\"mol.pqr\"\r\n" +
          "Content-Type: application/octet-stream\r\n\r\n" + pqr + "\r\n--" + boundary + "--\r\n";
  return body;
}

/// A complete POST of a multipart body to `target`.
inline std::string upload_request(const std::string& target, const std::string& pqr,
                                  const std::vector<std::pair<std::string, std::string>>& fields = {},
                                  const std::string& extra_headers = {}) {
  const std::string boundary = "----tracemesh-test-boundary";
  const std::string body = multipart_body(boundary, pqr, fields);
  return "POST " + target + " HTTP/1.1\r\nHost: test\r\nContent-Type: multipart/form-data; boundary=" + boundary +
         "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n" + extra_headers + "\r\n" + body;
}

/// One request on a fresh connection.
inline http_reply round_trip(unsigned short port, const std::string& request, bool head_request = false) {
  raw_connection connection(port);
  if (!connection.connected() || !connection.send(request)) return {};
  return connection.read_reply(head_request);
}

inline std::string get_request(const std::string& target, const std::string& extra_headers = {}) {
  return "GET " + target + " HTTP/1.1\r\nHost: test\r\n" + extra_headers + "\r\n";
}

}  // namespace tracemesh::testing
