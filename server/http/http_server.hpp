#pragma once
/// @file http_server.hpp
/// The HTTP transport of tracemeshd, after the Beast 1.74 advanced-server example: a listener accepting on a
/// strand, one session per connection on its own strand over a beast::tcp_stream, a fresh parser per request.
///
/// A session reads one request at a time and answers it before reading the next (pipelined requests wait in the
/// socket, so responses keep request order and at most one request per connection is in flight). Per request:
/// 1. the header block is read under max_header_bytes (431) and header_timeout (keep-alive idle + slow headers);
///    malformed framing — conflicting Content-Length values, Transfer-Encoding other than a lone "chunked" or
///    together with Content-Length — is refused with 400 and the connection closed (request smuggling); an
///    HTTP/1.1 request without exactly one Host field is refused with 400 (RFC 9112 §3.2);
/// 2. request_handler::plan() decides from the header alone: an immediate reply (errors, 413 from
///    Content-Length, 415...) or how to read the body; only then is "100 Continue" sent to an Expect: 100-continue;
/// 3. an upload body is streamed chunk by chunk into the multipart parser (never buffered whole; bodies are
///    counted against the limit while streaming → 413, and grow their upload_ticket's reservation by the bytes
///    received → 429 when the uploads in flight hold too many bytes) under the whole-request deadline
///    request_timeout; a body with Content-Encoding: gzip is gathered compressed and handed to the handler, which
///    decodes it off the I/O thread;
/// 4. the handler answers through a reply_sink, possibly much later from another thread: the reply is posted
///    back to the session's strand, so no I/O thread ever waits for a job;
/// 5. the response is written under write_timeout; errors that leave body bytes unread close the connection. A
///    reply marked compressible (JSON) of at least min_compressed_json_bytes is compressed here with the coding the
///    request's Accept-Encoding prefers; a reply's body_slice (a 206) is sent without a copy.
/// Every request gets a request id (a sane incoming X-Request-Id, else a generated one), echoed in X-Request-Id,
/// and one "access" log line when its response is written (error level for 5xx); its duration runs from the
/// request's first byte. Connections over max_connections first make the oldest idle keep-alive connection close;
/// with none idle, or when the connection's client is over max_connections_per_client (by IP address), it becomes
/// a probe connection: its one request is read under probe_header_timeout, answered when it is a health route
/// (handler's is_health_route), else 503 (server full) or 429 client_limit (client over its limit), and the
/// connection closed. Probes are bounded by health_connection_reserve; a new probe over it makes the oldest probe
/// that has sent nothing close (so silent connections cannot shut a health check out), and with none silent the
/// new connection gets 503 without being read. From a --trusted-proxy peer, the client is the one its request's
/// Forwarded / X-Forwarded-For names (admission/forwarded_client.hpp): for plan(), the access log, and the
/// connection limit, counted per request from its header to its response instead of per connection. An upload
/// body that falls behind min_upload_bytes_per_second after upload_rate_grace is answered 408 and closed. CORS
/// headers are added to every response.
/// The session itself lives in detail/http_session.hpp, a template over its stream (the request fuzzer runs it
/// over a Beast test stream).

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/string.hpp>
#include <boost/beast/http/message.hpp>
#include <spdlog/logger.h>

#include "core/status.hpp"
#include "server/admission/client_quota.hpp"
#include "server/http/cors.hpp"
#include "server/observability/metrics.hpp"
#include "server/http/multipart_parser.hpp"
#include "server/admission/server_limits.hpp"
#include "server/admission/upload_admission.hpp"

namespace tracemesh::server {

namespace net = boost::asio;
namespace http = boost::beast::http;

using request_head = http::request_header<>;

/// Beast 1.74 hands out boost::string_view; the rest of the code uses std::string_view.
inline std::string_view to_std(boost::beast::string_view text) { return {text.data(), text.size()}; }

/// Every Accept-Encoding field of the request as one comma-separated list (RFC 9110 §5.3); nullopt when it has none
/// (which negotiate_coding tells apart from an empty field).
std::optional<std::string> accept_encoding(const request_head& head);

/// The events of one Server-Sent Events response (GET /jobs/{id}/events), pulled by the session: it asks next()
/// once the response header is written, then again after each write and every limits.event_interval while nothing
/// is pending (so a stream costs a timer, never a thread), until a batch says `last`; then it ends the body and
/// closes the connection. It stops asking when the client goes away.
class event_source {
 public:
  struct batch {
    std::string text;   ///< zero or more complete events ("event: …\ndata: …\n\n"), written as they are
    bool last = false;  ///< the stream ends after this text
  };
  virtual ~event_source() = default;
  /// Calls `deliver` exactly once, from any thread (the session posts it back to its strand). Must not block.
  virtual void next(std::function<void(batch)> deliver) = 0;
};

/// A response as the application produces it; the session adds framing, keep-alive, Server and CORS headers.
struct reply {
  unsigned status = 200;
  std::string route;  ///< route template for metrics and logs ("/jobs/{id}"), never the raw target
  std::string content_type = "application/json";
  std::shared_ptr<const std::string> body;  ///< shared with caches: sent without a copy
  /// A 206's byte range: only body[offset, offset + length) is sent (and counted in Content-Length), still
  /// without a copy; nullopt sends the whole body.
  std::optional<std::pair<std::size_t, std::size_t>> body_slice;
  header_list headers;
  bool close = false;  ///< close the connection after this response
  /// JSON text (json_reply, error_reply): the session compresses it with gzip or br when the request's
  /// Accept-Encoding asks for one and it has at least min_compressed_json_bytes (content_coding.hpp), adding
  /// Content-Encoding and Vary. Mesh replies carry their (cached) coding themselves and leave this false.
  bool compressible = false;
  /// Set (status 200): the body is this event stream, sent chunked as it comes; the connection closes after it.
  std::shared_ptr<event_source> events;
};

/// The JSON error reply {"error": {"code", "message"}} (proto::error_body) with `status`.
reply error_reply(unsigned status, std::string_view code, std::string_view message, std::string route);
/// A JSON reply of `status` with the given body text.
reply json_reply(unsigned status, std::string body, std::string route);

/// 429 + Retry-After, code client_limit, for a client holding `limit` `what` already (limit_name: the setting).
reply client_limit_reply(std::string_view limit_name, std::size_t limit, std::string_view what,
                         unsigned retry_after_seconds, std::string route);

/// 429 client_limit for a client over max_connections_per_client; closes the connection.
reply client_connection_limit_reply(const server_limits& limits);

/// Delivers the reply to a request; callable from any thread, exactly once.
using reply_sink = std::function<void(reply)>;

/// How to read a request's body, decided from its header.
struct body_plan {
  std::string route;
  bool upload = false;            ///< multipart/form-data streamed into a multipart_parser
  /// Upload only: the body has Content-Encoding: gzip; it is gathered whole (compressed, under max_bytes) and
  /// given to handle_encoded_upload instead of being parsed while it streams.
  bool gzip_encoded = false;
  std::uint64_t max_bytes = 0;    ///< body limit (Content-Length was already checked against it)
  std::string boundary;           ///< upload only
  multipart_limits part_limits;   ///< upload only
  /// Upload only: the admission ticket (count and bytes in flight, and the client's upload lease), released when
  /// the last owner drops it.
  std::shared_ptr<upload_ticket> ticket;
  /// Who sent the request, for per-client limits: "token:<digest>" of its bearer token when the server
  /// authenticates, else "ip:<address>".
  std::string client;
};

/// The application: routes and handlers (api_handlers.hpp). plan() runs on an I/O thread and must be cheap.
class request_handler {
 public:
  virtual ~request_handler() = default;
  /// `client_address`: the client's IP address (the peer's, or the one a trusted proxy names); per-client limits key
  /// on it when no bearer token names the client.
  virtual std::variant<reply, body_plan> plan(const request_head& head, const std::string& client_address) = 0;
  /// A non-upload request whose (small) body has been read.
  virtual void handle(const request_head& head, const body_plan& plan, std::string body, reply_sink done) = 0;
  /// An upload whose multipart body has been parsed completely.
  virtual void handle_upload(const request_head& head, body_plan plan, std::vector<multipart_part> parts,
                             reply_sink done) = 0;
  /// An upload with plan.gzip_encoded whose compressed body has been read completely.
  virtual void handle_encoded_upload(const request_head& head, body_plan plan, std::string compressed_body,
                                     reply_sink done) = 0;
  /// Health routes (/healthz, /readyz) are answered even on connections over the connection limit.
  virtual bool is_health_route(std::string_view target) const = 0;
};

/// Idle keep-alive connections (waiting for the first byte of their next request), oldest first, so that a new
/// connection over the limit can make the oldest one close (as nginx reuses idle keep-alive connections).
class idle_connections {
 public:
  /// `close` makes the connection close if it is still idle (it runs on the caller's thread: post to a strand).
  std::uint64_t add(std::function<void()> close);
  void remove(std::uint64_t key);
  /// Takes the oldest idle connection out of the set and calls its close; false when none is idle.
  bool close_oldest();
  std::size_t size() const;

 private:
  mutable std::mutex mutex_;
  std::uint64_t next_key_ = 0;
  std::map<std::uint64_t, std::function<void()>> idle_;
};

/// Request ids: 16 hex digits, unique within the process (a bijective mix of a random seed and a counter).
class request_id_source {
 public:
  request_id_source();
  std::string next();
  /// An incoming X-Request-Id worth keeping: 1–128 bytes of letters, digits and "-_.:".
  static bool acceptable(std::string_view id);

 private:
  std::uint64_t seed_;
  std::atomic<std::uint64_t> counter_{0};
};

/// Counters shared by the listener, the sessions and the service.
struct http_server_state {
  explicit http_server_state(std::size_t max_connections_per_client = std::numeric_limits<std::size_t>::max())
      : client_connections(max_connections_per_client) {}

  std::atomic<std::size_t> open_connections{0};
  std::atomic<std::size_t> busy_requests{0};  ///< header read, response not yet written
  std::atomic<bool> draining{false};          ///< SIGTERM received: answer with Connection: close
  std::atomic<std::size_t> event_streams{0};  ///< open event streams (bounded by limits.max_event_streams)
  idle_connections idle;
  /// Probe connections (limits.health_connection_reserve) open, and those still waiting for their first byte.
  std::atomic<std::size_t> probe_connections{0};
  idle_connections probes;
  request_id_source request_ids;
  /// Open connections per client IP address (max_connections_per_client).
  client_quota client_connections;
};

/// Everything a session needs, owned by the service and outliving every session.
struct http_context {
  const server_limits& limits;
  request_handler& handler;
  http_server_state& state;
  metrics& stats;
  spdlog::logger& log;
  cors_policy cors;
};

class http_listener : public std::enable_shared_from_this<http_listener> {
 public:
  http_listener(net::io_context& io, http_context& context);

  /// Binds and listens on host:port (port 0 = ephemeral). errc::io_error naming the address on failure.
  status open(const std::string& host, unsigned short port);
  /// The bound port (after open()).
  unsigned short port() const { return port_; }
  /// Starts accepting (asynchronously, on the listener's strand).
  void run();
  /// Stops accepting: closes the acceptor on its strand. Open connections are not touched.
  void stop();

 private:
  void do_accept();
  void on_accept(boost::system::error_code ec, net::ip::tcp::socket socket);
  /// Lets a new connection in, as a probe connection, or refuses it (see the file comment).
  template <class Session>
  void admit(const std::shared_ptr<Session>& connection, const std::string& client);

  net::io_context& io_;
  http_context& context_;
  net::strand<net::io_context::executor_type> strand_;
  net::ip::tcp::acceptor acceptor_;
  net::steady_timer accept_retry_;  // limits.accept_error_pause after a failed accept
  unsigned short port_ = 0;
};

}  // namespace tracemesh::server
