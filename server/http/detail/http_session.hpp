#pragma once
/// @file detail/http_session.hpp
/// One HTTP connection of tracemeshd (see http_server.hpp for the request life cycle), as a template over its
/// byte stream: beast::tcp_stream in the server, a Beast test stream in the request fuzzer
/// (tests/fuzz/http_request_fuzzer.cpp). A stream type plugs in through a stream_transport specialisation that
/// arms and disarms deadlines and closes the connection.

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/range/iterator_range.hpp>

#include "server/admission/forwarded_client.hpp"
#include "server/http/content_coding.hpp"
#include "server/http/http_server.hpp"
#include "server/observability/logging.hpp"

namespace tracemesh::server::detail {

namespace beast = boost::beast;

/// Deadlines and closing for a stream type: expire_after(stream, duration), expire_at(stream, time_point),
/// expire_never(stream), close(stream). Specialised below for beast::tcp_stream.
template <class Stream>
struct stream_transport;

template <>
struct stream_transport<beast::tcp_stream> {
  static void expire_after(beast::tcp_stream& s, std::chrono::steady_clock::duration d) { s.expires_after(d); }
  static void expire_at(beast::tcp_stream& s, std::chrono::steady_clock::time_point t) { s.expires_at(t); }
  static void expire_never(beast::tcp_stream& s) { s.expires_never(); }
  /// Ends the pending read or write with operation_aborted, leaving the connection open (to answer 408).
  static void cancel(beast::tcp_stream& s) { s.cancel(); }
  static void close(beast::tcp_stream& s) {
    shutdown_send(s);
    s.close();
  }
  /// Sends FIN and leaves the receiving side open (lingering_close below).
  static void shutdown_send(beast::tcp_stream& s) {
    beast::error_code ignored;
    s.socket().shutdown(net::ip::tcp::socket::shutdown_send, ignored);
  }
  /// Bytes received by the socket and not yet read (an "idle" connection whose request is arriving).
  static bool has_unread_bytes(beast::tcp_stream& s) {
    beast::error_code ec;
    return s.socket().available(ec) > 0 && !ec;
  }
  /// The peer's address for the access log ("" when the socket is already gone).
  static std::string client_address(beast::tcp_stream& s) {
    beast::error_code ec;
    const auto endpoint = s.socket().remote_endpoint(ec);
    return ec ? std::string() : endpoint.address().to_string();
  }
};

/// Bytes read from the stream per body read: the multipart parser sees the upload in pieces of at most this.
inline constexpr std::size_t body_chunk_bytes = 64 * 1024;

/// Bytes asked for by the read that waits for a request's first bytes (the rest of the header follows).
inline constexpr std::size_t first_read_bytes = 4096;

/// The request and response header carrying the request id.
inline constexpr const char* request_id_field = "X-Request-Id";
/// Sent on every response: browsers must take Content-Type as it is and never sniff a mesh or an error body
/// into something they would run.
inline constexpr const char* content_type_options_field = "X-Content-Type-Options";

/// The route label used for requests rejected before routing.
inline constexpr const char* unrouted_route = "(unrouted)";

inline bool expects_continue(const request_head& head) {
  return beast::iequals(head[http::field::expect], "100-continue");
}

/// True when the request has no Transfer-Encoding or exactly the one coding "chunked". Anything else makes the
/// body length undecidable or needs a decoder we do not have (RFC 9112 §6.1, §6.3): such requests are refused
/// and the connection closed. Beast 1.74 alone would ignore a coding list not ending in "chunked", and accept
/// "Transfer-Encoding: gzip" followed by a Content-Length — both classic request-smuggling shapes.
inline bool transfer_encoding_acceptable(const request_head& head) {
  std::size_t codings = 0;
  bool chunked = false;
  for (const auto& field : boost::make_iterator_range(head.equal_range(http::field::transfer_encoding))) {
    for (const auto& coding : http::token_list{field.value()}) {
      ++codings;
      chunked = beast::iequals(coding, "chunked");
    }
  }
  const bool present = head.find(http::field::transfer_encoding) != head.end();
  return !present || (codings == 1 && chunked && head.find(http::field::content_length) == head.end());
}

/// True when `value` is a Host field value (RFC 9110 §7.2: uri-host [":" port], RFC 3986 §3.2.2): empty (a
/// target without authority), an IP-literal in brackets, or a reg-name / IPv4 address of unreserved, percent-encoded
/// and sub-delim characters; then an optional port of digits. Spaces, '/', '@', control bytes and the like are not.
inline bool host_value_valid(std::string_view value) {
  const auto is_port = [](std::string_view port) {
    return std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!value.empty() && value.front() == '[') {
    const std::size_t close = value.find(']');
    if (close == std::string_view::npos || close == 1) return false;
    const std::string_view literal = value.substr(1, close - 1);
    const bool literal_chars = std::all_of(literal.begin(), literal.end(), [](char c) {
      return std::isxdigit(static_cast<unsigned char>(c)) || c == ':' || c == '.' || c == 'v' || c == 'V';
    });
    const std::string_view rest = value.substr(close + 1);
    return literal_chars && (rest.empty() || (rest.front() == ':' && is_port(rest.substr(1))));
  }
  const std::size_t colon = value.rfind(':');
  const std::string_view host = value.substr(0, colon);
  if (colon != std::string_view::npos && !is_port(value.substr(colon + 1))) return false;
  for (std::size_t i = 0; i < host.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(host[i]);
    if (std::isalnum(c) || std::string_view("-._~!$&'()*+,;=").find(static_cast<char>(c)) != std::string_view::npos) {
      continue;
    }
    if (c == '%' && i + 2 < host.size() && std::isxdigit(static_cast<unsigned char>(host[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(host[i + 2]))) {
      i += 2;
      continue;
    }
    return false;
  }
  return true;
}

/// The refusal of a request without exactly one Host field.
inline constexpr const char* missing_host_message = "an HTTP/1.1 request must carry exactly one Host header field";

/// Why the request's Host fields are refused (400), or nothing: an HTTP/1.1 request carries exactly one Host field
/// (RFC 9112 §3.2), and any Host value must be valid (RFC 9110 §7.2). HTTP/1.0 need not send one.
inline std::optional<std::string> host_problem(const request_head& head) {
  const auto hosts = head.equal_range(http::field::host);
  const auto count = std::distance(hosts.first, hosts.second);
  if (head.version() >= 11 && count != 1) return std::string(missing_host_message);
  for (const auto& field : boost::make_iterator_range(hosts)) {
    if (!host_value_valid(to_std(field.value()))) return "the Host header field is not a host[:port]";
  }
  return std::nullopt;
}

/// One connection. Lives as long as an operation or a pending reply holds a shared_ptr to it.
template <class Stream>
class http_session : public std::enable_shared_from_this<http_session<Stream>> {
  using transport = stream_transport<Stream>;
  using clock = std::chrono::steady_clock;

 public:
  http_session(Stream&& stream, http_context& context)
      : stream_(std::move(stream)),
        context_(context),
        peer_(transport::client_address(stream_)),
        from_trusted_proxy_(in_networks(context_.limits.trusted_proxies, peer_)),
        client_(peer_),
        rate_timer_(stream_.get_executor()) {
    context_.state.open_connections.fetch_add(1, std::memory_order_relaxed);
  }
  ~http_session() {
    stop_being_idle();
    if (health_only_) context_.state.probe_connections.fetch_sub(1, std::memory_order_relaxed);
    context_.state.open_connections.fetch_sub(1, std::memory_order_relaxed);
  }
  http_session(const http_session&) = delete;
  http_session& operator=(const http_session&) = delete;

  void run() {
    net::dispatch(stream_.get_executor(), [self = this->shared_from_this()] { self->read_header(); });
  }

  /// A probe connection (over the server's or its client's connection limit; limits.health_connection_reserve):
  /// one request is read under limits.probe_header_timeout; a health route is answered, anything else gets
  /// `refusal`; then the connection is closed. Until its first byte arrives it waits in state.probes, so a newer
  /// probe can make it give way when the reserve is full.
  void run_probe(reply refusal) {
    health_only_ = true;
    context_.state.probe_connections.fetch_add(1, std::memory_order_relaxed);
    health_only_refusal_ = std::move(refusal);
    run();
  }

  /// The peer is in a --trusted-proxy network: each request names its client (forwarded_client.hpp).
  bool from_trusted_proxy() const { return from_trusted_proxy_; }

  /// 503 + Retry-After, closing: the server has no connection to spare.
  static reply too_many_connections(unsigned retry_after_seconds) {
    reply busy = error_reply(503, "unavailable", "too many connections", unrouted_route);
    busy.headers.emplace_back("Retry-After", std::to_string(retry_after_seconds));
    busy.close = true;
    return busy;
  }

  /// Keeps `lease` (this connection counted against its client) as long as the session lives.
  void hold(std::shared_ptr<client_lease> lease) { client_lease_ = std::move(lease); }

  /// Past the connection limit and its health reserve: answer 503 and close without reading.
  void refuse() {
    net::dispatch(stream_.get_executor(), [self = this->shared_from_this()] {
      self->request_started_ = clock::now();
      self->head_.version(11);
      self->begin_request();
      self->send(too_many_connections(self->context_.limits.retry_after_seconds));
    });
  }

 private:
  // ---- reading the header ------------------------------------------------------------------------------------

  void read_header() {
    header_parser_.emplace();
    header_parser_->header_limit(context_.limits.max_header_bytes);
    // The real limit is set per route once plan() has seen the header. Not boost::none: Beast 1.74 compares
    // Content-Length against the optional, and any length is "greater" than an empty optional.
    header_parser_->body_limit(std::numeric_limits<std::uint64_t>::max());
    body_parser_.reset();
    small_parser_.reset();
    multipart_.reset();
    plan_ = body_plan{};
    upload_bytes_ = 0;
    rate_violated_ = false;
    skipped_empty_line_bytes_ = 0;
    encoded_body_.clear();
    client_ = peer_;  // until a trusted proxy's next request names its client
    // header_timeout runs from here: keep-alive idle time and a slow header together.
    transport::expire_after(stream_, health_only_ ? context_.limits.probe_header_timeout
                                                  : context_.limits.header_timeout);
    if (buffer_.size() > 0) {  // a pipelined request is already here
      request_started_ = clock::now();
      return read_header_block();
    }
    wait_for_request();
  }

  /// Idle: waits for the first bytes of the next request (their arrival starts the request's clock). Meanwhile a
  /// new connection over the limit (a new probe, for a probe) may make this one close (close_if_idle).
  void wait_for_request() {
    idle_key_ = idle_set().add(
        [weak = std::weak_ptr<http_session>(this->shared_from_this()), key = next_idle_generation()] {
          if (auto self = weak.lock()) {
            net::dispatch(self->stream_.get_executor(), [self, key] { self->close_if_idle(key); });
          }
        });
    idle_ = true;
    stream_.async_read_some(buffer_.prepare(first_read_bytes),
                            beast::bind_front_handler(&http_session::on_first_bytes, this->shared_from_this()));
  }

  void on_first_bytes(beast::error_code ec, std::size_t bytes) {
    stop_being_idle();
    if (ec) return close();  // idle keep-alive expired, client gone, or closed to make room
    buffer_.commit(bytes);
    request_started_ = clock::now();
    read_header_block();
  }

  /// RFC 9112 §2.2: a server should ignore empty lines before a request line (clients send a CRLF after a body
  /// now and then). Drops them, up to max_header_bytes per request (more is a malformed request for the parser);
  /// true when the buffer then holds nothing but the start of one (more bytes are needed).
  bool skip_empty_lines() {
    const auto* bytes = static_cast<const char*>(buffer_.data().data());
    const std::string_view held(bytes, buffer_.size());
    std::size_t skip = 0;
    while (skip < held.size() && skipped_empty_line_bytes_ + skip < context_.limits.max_header_bytes) {
      if (held[skip] == '\n') {
        ++skip;
      } else if (held[skip] == '\r' && skip + 1 < held.size() && held[skip + 1] == '\n') {
        skip += 2;
      } else {
        break;
      }
    }
    buffer_.consume(skip);
    skipped_empty_line_bytes_ += skip;
    const bool lone_cr = buffer_.size() == 1 && *static_cast<const char*>(buffer_.data().data()) == '\r';
    return (buffer_.size() == 0 || lone_cr) && skipped_empty_line_bytes_ < context_.limits.max_header_bytes;
  }

  std::uint64_t next_idle_generation() { return ++idle_generation_; }

  void close_if_idle(std::uint64_t generation) {
    // A request began meanwhile, or its bytes are arriving: the new connection over the limit is let in anyway
    // (the limit is exceeded by at most the connections caught in this race).
    if (!idle_ || generation != idle_generation_ || transport::has_unread_bytes(stream_)) return;
    idle_key_.reset();  // already taken out of the idle set
    idle_ = false;
    // A silent probe is one of a flood's connections: debug level, or the flood would fill the log.
    log_event(context_.log, health_only_ ? spdlog::level::debug : spdlog::level::info, "idle_connection_closed",
              {{"client", client_},
               {"reason", health_only_ ? "probe reserve full" : "connection limit reached"}});
    transport::close(stream_);  // the pending read ends with an error and the session goes away
  }

  void stop_being_idle() {
    idle_ = false;
    if (idle_key_) idle_set().remove(*idle_key_);
    idle_key_.reset();
  }

  /// Where this connection waits while idle: probes give way only to probes.
  idle_connections& idle_set() { return health_only_ ? context_.state.probes : context_.state.idle; }

  void read_header_block() {
    if (skip_empty_lines()) {
      return stream_.async_read_some(buffer_.prepare(first_read_bytes), beast::bind_front_handler(
                                         &http_session::on_more_header_bytes, this->shared_from_this()));
    }
    http::async_read_header(stream_, buffer_, *header_parser_,
                            beast::bind_front_handler(&http_session::on_header, this->shared_from_this()));
  }

  void on_more_header_bytes(beast::error_code ec, std::size_t bytes) {
    if (ec) return close();  // the header deadline passed, or the client left, with only empty lines sent
    buffer_.commit(bytes);
    read_header_block();
  }

  void on_header(beast::error_code ec, std::size_t header_bytes) {
    // Beast's header_limit does not count the request line: the documented limit (request line and fields) is
    // checked here, on the bytes the header really took.
    if (!ec && header_bytes > context_.limits.max_header_bytes) ec = http::error::header_limit;
    if (ec) return on_header_error(ec);
    head_ = header_parser_->get().base();
    keep_alive_ = header_parser_->keep_alive();
    begin_request();
    if (!transfer_encoding_acceptable(head_)) {
      return send(error_reply(400, "bad_request",
                              "Transfer-Encoding must be the single coding \"chunked\", without Content-Length",
                              unrouted_route),
                  /*force_close=*/true);
    }
    if (const std::optional<std::string> problem = host_problem(head_)) {
      // A missing Host on a request read whole leaves the connection usable; a malformed Host value says the
      // client (or a proxy before it) is confused about what it talks to: the connection ends.
      const bool malformed_value = *problem != missing_host_message;
      return send(error_reply(400, "bad_request", *problem, unrouted_route),
                  /*force_close=*/malformed_value || !header_parser_->is_done());
    }
    if (from_trusted_proxy_) client_ = forwarded_client_of(head_);
    const bool health_route = context_.handler.is_health_route(to_std(head_.target()));
    if (health_only_ && !health_route) return send(health_only_refusal_, /*force_close=*/true);
    if (from_trusted_proxy_ && !health_only_) {
      // A proxy's connection counts against the client of the request it carries, until it is answered.
      request_lease_ = context_.state.client_connections.acquire(client_);
      if (!request_lease_ && !health_route) {
        return send(client_connection_limit_reply(context_.limits), /*force_close=*/true);
      }
    }
    std::variant<reply, body_plan> decision = context_.handler.plan(head_, client_);
    if (auto* immediate = std::get_if<reply>(&decision)) {
      // The body (if any) is left unread: the connection cannot be reused.
      if (!header_parser_->is_done()) immediate->close = true;
      return send(std::move(*immediate));
    }
    plan_ = std::move(std::get<body_plan>(decision));
    if (header_parser_->is_done()) return body_complete_without_bytes();
    if (expects_continue(head_)) return send_continue();
    read_body();
  }

  void on_header_error(beast::error_code ec) {
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == net::error::eof ||
        ec == net::error::connection_reset || ec == net::error::operation_aborted) {
      return close();  // idle keep-alive expired, client gone, or a slow header cut at the deadline
    }
    head_ = request_head{};
    head_.version(11);
    begin_request();
    if (ec == http::error::header_limit) {
      return send(error_reply(431, "header_too_large",
                              "the request header exceeds " + std::to_string(context_.limits.max_header_bytes) +
                                  " bytes",
                              unrouted_route),
                  /*force_close=*/true);
    }
    if (ec == http::error::partial_message) return close();
    send(error_reply(400, "bad_request", "malformed HTTP request: " + ec.message(), unrouted_route), true);
  }

  /// The client a trusted proxy's request names (Forwarded, else X-Forwarded-For), or the proxy itself.
  std::string forwarded_client_of(const request_head& head) const {
    std::vector<std::string_view> forwarded;
    std::vector<std::string_view> x_forwarded_for;
    for (const auto& field : head) {
      if (beast::iequals(field.name_string(), "Forwarded")) forwarded.push_back(to_std(field.value()));
      if (beast::iequals(field.name_string(), "X-Forwarded-For")) x_forwarded_for.push_back(to_std(field.value()));
    }
    return forwarded_client(peer_, forwarded, x_forwarded_for, context_.limits.trusted_proxies);
  }

  /// The header is in (or the request is refused): count the request busy and give it its id.
  void begin_request() {
    if (!busy_) context_.state.busy_requests.fetch_add(1, std::memory_order_relaxed);
    busy_ = true;
    const std::string_view incoming = to_std(head_[request_id_field]);
    request_id_ = request_id_source::acceptable(incoming) ? std::string(incoming)
                                                          : context_.state.request_ids.next();
  }

  void send_continue() {
    continue_ = http::response<http::empty_body>{http::status::continue_, head_.version()};
    transport::expire_after(stream_, context_.limits.write_timeout);
    http::async_write(stream_, continue_, [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->close();
      self->read_body();
    });
  }

  // ---- reading the body --------------------------------------------------------------------------------------

  void read_body() {
    header_parser_->body_limit(plan_.max_bytes);
    if (plan_.upload) {
      const boost::optional<std::uint64_t> length = header_parser_->content_length();
      body_parser_.emplace(std::move(*header_parser_));
      // plan() checked the length against the upload limit, so the body may reserve it at once.
      if (plan_.gzip_encoded) {
        if (length) encoded_body_.reserve(static_cast<std::size_t>(*length));
      } else {
        multipart_.emplace(plan_.boundary, plan_.part_limits);
        if (length) multipart_->set_body_size_hint(static_cast<std::size_t>(*length));
      }
      chunk_.resize(body_chunk_bytes);
      body_started_ = clock::now();
      arm_rate_check();
      return read_upload_chunk();
    }
    small_parser_.emplace(std::move(*header_parser_));
    transport::expire_at(stream_, request_started_ + context_.limits.request_timeout);
    http::async_read(stream_, buffer_, *small_parser_,
                     beast::bind_front_handler(&http_session::on_small_body, this->shared_from_this()));
  }

  void on_small_body(beast::error_code ec, std::size_t) {
    if (ec) return on_body_error(ec);
    transport::expire_never(stream_);
    context_.handler.handle(head_, plan_, std::move(small_parser_->get().body()), make_sink());
  }

  void read_upload_chunk() {
    auto& body = body_parser_->get().body();
    body.data = chunk_.data();
    body.size = chunk_.size();
    transport::expire_at(stream_, request_started_ + context_.limits.request_timeout);
    http::async_read_some(stream_, buffer_, *body_parser_,
                          beast::bind_front_handler(&http_session::on_upload_chunk, this->shared_from_this()));
  }

  void on_upload_chunk(beast::error_code ec, std::size_t) {
    if (rate_violated_) return on_body_error(ec);  // the read completed just as the rate deadline cancelled it
    if (ec == http::error::need_buffer) ec = {};
    if (ec) return on_body_error(ec);
    const std::size_t received = chunk_.size() - body_parser_->get().body().size;
    upload_bytes_ += received;
    arm_rate_check();
    // A chunked body declared no size: its memory reservation grows with what has arrived.
    if (plan_.ticket && !plan_.ticket->reserve_total(upload_bytes_)) return refuse_upload_bytes();
    if (plan_.gzip_encoded) {
      encoded_body_.append(chunk_.data(), received);
    } else if (const status fed = multipart_->feed(std::string_view(chunk_.data(), received)); !fed.ok()) {
      return reject_upload(fed);
    }
    if (!body_parser_->is_done()) return read_upload_chunk();
    stop_rate_check();
    transport::expire_never(stream_);
    chunk_ = {};
    if (plan_.gzip_encoded) {
      return context_.handler.handle_encoded_upload(head_, std::move(plan_), std::move(encoded_body_), make_sink());
    }
    const status finished = multipart_->finish();
    if (!finished.ok()) return reject_upload(finished);
    std::vector<multipart_part> parts = std::move(multipart_->parts());
    multipart_.reset();
    context_.handler.handle_upload(head_, std::move(plan_), std::move(parts), make_sink());
  }

  // ---- the minimum upload rate -------------------------------------------------------------------------------
  // After upload_rate_grace from the end of the header, the body must have received min_upload_bytes_per_second
  // × (elapsed − grace) bytes. The timer is set to the moment the bytes received so far fall behind, and moved on
  // with every chunk; when it fires, the pending read is cancelled and the upload answered 408.

  void arm_rate_check() {
    const std::uint64_t rate = context_.limits.min_upload_bytes_per_second;
    if (rate == 0) return;
    const auto allowance = std::chrono::duration_cast<clock::duration>(
        std::chrono::duration<double>(static_cast<double>(upload_bytes_) / static_cast<double>(rate)));
    rate_timer_.expires_at(body_started_ + context_.limits.upload_rate_grace + allowance);
    rate_timer_.async_wait([weak = std::weak_ptr<http_session>(this->shared_from_this())](beast::error_code ec) {
      if (auto self = weak.lock(); self && !ec) self->on_rate_deadline();
    });
  }

  void stop_rate_check() { rate_timer_.cancel(); }

  void on_rate_deadline() {
    if (!body_parser_ || body_parser_->is_done() || rate_violated_) return;
    rate_violated_ = true;
    transport::cancel(stream_);  // the pending read ends with operation_aborted: on_body_error answers 408
  }

  void refuse_slow_upload() {
    log_event(context_.log, spdlog::level::info, "upload_too_slow",
              {{"request_id", request_id_},
               {"client", client_},
               {"route", plan_.route},
               {"body_bytes", upload_bytes_},
               {"ms", std::chrono::duration<double, std::milli>(clock::now() - body_started_).count()}});
    send(error_reply(408, "request_timeout",
                     "the upload body arrived slower than " +
                         std::to_string(context_.limits.min_upload_bytes_per_second) +
                         " bytes per second (after a grace time of " +
                         std::to_string(context_.limits.upload_rate_grace.count()) + " ms)",
                     plan_.route),
         /*force_close=*/true);
  }

  void body_complete_without_bytes() {
    transport::expire_never(stream_);
    if (!plan_.upload) return context_.handler.handle(head_, plan_, std::string(), make_sink());
    reject_upload(status(errc::invalid_input, "the request has no body: expected a multipart/form-data upload"));
  }

  void reject_upload(const status& error) {
    const bool too_large = error.code() == errc::limit_exceeded;
    send(error_reply(too_large ? 413 : 400, errc_name(error.code()), error.message(), plan_.route),
         /*force_close=*/!parser_done());
  }

  void refuse_upload_bytes() {
    reply busy = error_reply(429, "queue_full", "too many upload bytes in progress; retry later", plan_.route);
    busy.headers.emplace_back("Retry-After", std::to_string(context_.limits.retry_after_seconds));
    send(std::move(busy), /*force_close=*/true);
  }

  void on_body_error(beast::error_code ec) {
    stop_rate_check();
    if (rate_violated_) return refuse_slow_upload();
    if (ec == http::error::body_limit) {
      return send(error_reply(413, "limit_exceeded",
                              "the request body exceeds " + std::to_string(plan_.max_bytes) + " bytes",
                              plan_.route),
                  true);
    }
    if (ec == beast::error::timeout || ec == http::error::partial_message || ec == net::error::eof ||
        ec == net::error::connection_reset || ec == http::error::end_of_stream) {
      log_event(context_.log, spdlog::level::info, "request_aborted",
                {{"request_id", request_id_},
                 {"client", client_},
                 {"method", std::string(head_.method_string())},
                 {"route", plan_.route},
                 {"reason", ec.message()},
                 {"body_bytes", upload_bytes_},
                 {"ms", std::chrono::duration<double, std::milli>(clock::now() - request_started_).count()}});
      return close();
    }
    send(error_reply(400, "bad_request", "malformed request body: " + ec.message(), plan_.route), true);
  }

  bool parser_done() const {
    if (body_parser_) return body_parser_->is_done();
    if (small_parser_) return small_parser_->is_done();
    return header_parser_ && header_parser_->is_done();
  }

  // ---- writing the response ----------------------------------------------------------------------------------

  /// A reply_sink that hands the reply back to this session's executor, from whatever thread calls it.
  /// dispatch: a handler answering at once (a memory cache hit) runs send() inline; other threads queue it.
  reply_sink make_sink() {
    return [self = this->shared_from_this()](reply r) {
      net::dispatch(self->stream_.get_executor(), [self, r = std::move(r)]() mutable { self->send(std::move(r)); });
    };
  }

  void send(reply r, bool force_close = false) {
    if (r.events) return start_event_stream(std::move(r));
    // The request's resources (upload reservation, parsers) are no longer needed once its answer is known.
    stop_rate_check();
    plan_.ticket.reset();
    multipart_.reset();
    const bool head_request = head_.method() == http::verb::head;
    const bool keep_alive =
        !force_close && !r.close && keep_alive_ && !health_only_ &&
        !context_.state.draining.load(std::memory_order_relaxed);
    response_body_ = r.body ? r.body : std::make_shared<const std::string>();
    if (r.compressible && !(r.status == 204 || r.status == 304)) compress_json(r);
    response_.emplace(static_cast<http::status>(r.status), head_.version() == 10 ? 10 : 11);
    response_->set(http::field::server, "tracemeshd");
    response_->set(content_type_options_field, "nosniff");
    const bool bodiless_status = r.status == 204 || r.status == 304;
    if (!bodiless_status) response_->set(http::field::content_type, r.content_type);
    const std::string origin(head_[http::field::origin]);
    context_.cors.add_response_headers(origin, r.headers);
    for (const auto& [name, value] : r.headers) response_->insert(name, value);
    response_->set(request_id_field, request_id_);
    const auto [offset, length] = r.body_slice.value_or(std::pair<std::size_t, std::size_t>{0, response_body_->size()});
    if (head_request || bodiless_status) {
      response_->body() = {};
    } else {
      response_->body() = http::span_body<const char>::value_type(response_body_->data() + offset, length);
    }
    response_->keep_alive(keep_alive);
    if (!bodiless_status) response_->content_length(length);
    context_.stats.count_request(r.route, r.status);
    transport::expire_after(stream_, context_.limits.write_timeout);
    http::async_write(stream_, *response_,
                      [self = this->shared_from_this(), keep_alive, route = std::move(r.route),
                       status = r.status](beast::error_code ec, std::size_t bytes) {
                        self->log_access(route, status, bytes, ec);
                        self->on_write(ec, keep_alive);
                      });
  }

  /// A JSON reply compressed on the fly (they are small: job documents, errors, the OpenAPI document) with the
  /// coding the request prefers; identity when it asks for none, is too short or refuses every coding (then
  /// identity is sent all the same: a 406 for a JSON document would help nobody, RFC 9110 §12.5.3 allows it).
  void compress_json(reply& r) {
    if (response_body_->size() < min_compressed_json_bytes) return;
    r.headers.emplace_back("Vary", "Accept-Encoding");
    const std::optional<std::string> accept = accept_encoding(head_);
    const std::optional<content_coding> coding =
        negotiate_coding(accept ? std::optional<std::string_view>(*accept) : std::nullopt, true);
    if (!coding || *coding == content_coding::identity) return;
    result<std::string> compressed = compress(*response_body_, *coding);
    if (!compressed.ok()) return;  // out of memory: the plain text still answers
    response_body_ = std::make_shared<const std::string>(std::move(*compressed));
    r.headers.emplace_back("Content-Encoding", std::string(coding_name(*coding)));
  }

  // ---- Server-Sent Events ------------------------------------------------------------------------------------
  // The response header, then the event source's batches as they come (chunked for HTTP/1.1, close-delimited for
  // HTTP/1.0), then the connection is closed. Between writes a read waits on the socket to notice the client
  // leaving (or sending anything, which ends the stream too); a timer paces the source. Only writes have a
  // deadline (write_timeout): a stream may stay quiet for as long as its job runs, and it is busy, never idle, so
  // the connection limit never closes it to make room.

  void start_event_stream(reply r) {
    plan_.ticket.reset();
    events_ = std::move(r.events);
    stream_route_ = std::move(r.route);
    chunked_ = head_.version() >= 11;
    stream_response_.emplace(http::status::ok, head_.version() == 10 ? 10 : 11);
    stream_response_->set(http::field::server, "tracemeshd");
    stream_response_->set(content_type_options_field, "nosniff");
    stream_response_->set(http::field::content_type, "text/event-stream");
    stream_response_->set(http::field::cache_control, "no-store");
    const std::string origin(head_[http::field::origin]);
    context_.cors.add_response_headers(origin, r.headers);
    for (const auto& [name, value] : r.headers) stream_response_->insert(name, value);
    stream_response_->set(request_id_field, request_id_);
    stream_response_->keep_alive(false);
    if (chunked_) stream_response_->chunked(true);
    context_.stats.count_request(stream_route_, 200);
    stream_serializer_.emplace(*stream_response_);
    event_timer_.emplace(stream_.get_executor());
    last_event_write_ = clock::now();
    transport::expire_after(stream_, context_.limits.write_timeout);
    http::async_write_header(stream_, *stream_serializer_,
                             [self = this->shared_from_this()](beast::error_code ec, std::size_t bytes) {
                               self->stream_bytes_ += bytes;
                               if (ec) return self->end_event_stream(ec);
                               transport::expire_never(self->stream_);
                               self->watch_event_client();
                               self->pull_events();
                             });
  }

  /// Any completion of this read ends the stream: the client closed, reset, or sent bytes it should not have.
  void watch_event_client() {
    stream_.async_read_some(buffer_.prepare(first_read_bytes),
                            [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
                              self->end_event_stream(ec ? ec : beast::error_code(net::error::connection_aborted));
                            });
  }

  void pull_events() {
    if (stream_ended_) return;
    events_->next([self = this->shared_from_this()](event_source::batch next) {
      net::dispatch(self->stream_.get_executor(),
                    [self, next = std::move(next)]() mutable { self->on_events(std::move(next)); });
    });
  }

  void on_events(event_source::batch next) {
    if (stream_ended_) return;
    const bool keepalive_due = clock::now() - last_event_write_ >= context_.limits.event_keepalive;
    if (next.text.empty() && !next.last && !keepalive_due) return wait_for_events();
    if (next.text.empty() && !next.last) next.text = ": keep-alive\n\n";
    write_events(std::move(next.text), next.last);
  }

  void wait_for_events() {
    event_timer_->expires_after(context_.limits.event_interval);
    event_timer_->async_wait([self = this->shared_from_this()](beast::error_code ec) {
      if (!ec) self->pull_events();
    });
  }

  void write_events(std::string text, bool last) {
    stream_text_ = std::move(text);
    last_event_write_ = clock::now();
    transport::expire_after(stream_, context_.limits.write_timeout);
    const auto on_written = [self = this->shared_from_this(), last](beast::error_code ec, std::size_t bytes) {
      self->stream_bytes_ += bytes;
      if (ec) return self->end_event_stream(ec);
      transport::expire_never(self->stream_);
      if (last) return self->end_event_stream({});
      self->wait_for_events();
    };
    if (!chunked_) return net::async_write(stream_, net::buffer(stream_text_), on_written);
    if (!last) return net::async_write(stream_, http::make_chunk(net::buffer(stream_text_)), on_written);
    // The last events and the terminating chunk in one write.
    net::async_write(stream_, http::make_chunk(net::buffer(stream_text_)),
                     [self = this->shared_from_this(), on_written](beast::error_code ec, std::size_t bytes) mutable {
                       if (ec) return on_written(ec, bytes);
                       self->stream_bytes_ += bytes;
                       net::async_write(self->stream_, http::make_chunk_last(), on_written);
                     });
  }

  /// Ends the stream once (`ec`: why, empty when the source said last) and closes the connection.
  void end_event_stream(beast::error_code ec) {
    if (stream_ended_) return;
    stream_ended_ = true;
    if (event_timer_) event_timer_->cancel();
    log_access(stream_route_, 200, stream_bytes_, ec);
    events_.reset();  // gives the stream's slot back
    close();
  }

  /// The access line of the request just answered; error level for 5xx. `bytes`: what reached the socket
  /// (status line, header and body); the duration runs from the request's first byte.
  void log_access(const std::string& route, unsigned status, std::size_t bytes, beast::error_code ec) {
    nlohmann::json fields = {
        {"request_id", request_id_},
        {"client", client_},
        {"method", head_.method() == http::verb::unknown ? std::string("-") : std::string(head_.method_string())},
        {"route", route},
        {"status", status},
        {"bytes", bytes},
        {"ms", std::chrono::duration<double, std::milli>(clock::now() - request_started_).count()}};
    if (client_ != peer_) fields["peer"] = peer_;  // through a trusted proxy
    if (ec) fields["write_error"] = ec.message();
    log_event(context_.log, status >= 500 ? spdlog::level::err : spdlog::level::info, "access", fields);
  }

  void on_write(beast::error_code ec, bool keep_alive) {
    end_request();
    request_lease_.reset();
    response_.reset();
    response_body_.reset();
    if (ec) return close();
    if (!keep_alive) return parser_done() && !transport::has_unread_bytes(stream_) ? close() : lingering_close();
    read_header();
  }

  /// Ends the connection after a response that closes it while the request's body may still be on its way (an
  /// upload refused with 413 or 429 before it was read, a slow body cut with 408). Closing a socket with unread bytes
  /// makes the kernel send RST, and a client still sending then loses the response it had not yet read: it sees
  /// "connection reset" instead of the status. So, as RFC 9112 §9.6 asks and nginx's lingering close does: send
  /// FIN, read and drop what the client still sends until it closes or limits.linger_time has passed, then close.
  void lingering_close() {
    release_request();  // the upload budget and slot go back now, not after the linger
    transport::shutdown_send(stream_);
    transport::expire_at(stream_, clock::now() + context_.limits.linger_time);
    chunk_.resize(body_chunk_bytes);
    drop_until_closed();
  }

  void drop_until_closed() {
    stream_.async_read_some(net::buffer(chunk_), [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->close();  // the client closed (eof), or linger_time passed
      self->drop_until_closed();
    });
  }

  void end_request() {
    if (busy_) context_.state.busy_requests.fetch_sub(1, std::memory_order_relaxed);
    busy_ = false;
  }

  void close() {
    release_request();
    transport::close(stream_);
  }

  /// What a connection holds for its current request: the rate check, its idle entry, the busy count, the upload
  /// ticket. Released once the connection is ending, whether it closes at once or lingers.
  void release_request() {
    stop_rate_check();
    stop_being_idle();
    end_request();
    plan_.ticket.reset();
    request_lease_.reset();
  }

  Stream stream_;
  http_context& context_;
  const std::string peer_;        // the peer's address
  const bool from_trusted_proxy_;  // peer_ is in limits.trusted_proxies
  std::string client_;  // who sent the current request (peer_, or the client a trusted proxy names), for the log
  std::string request_id_;
  bool health_only_ = false;  // a probe connection (run_probe): one health request, then close
  reply health_only_refusal_;  // health_only_: the answer to anything but a health route
  std::shared_ptr<client_lease> client_lease_;  // this connection counted against its client's connection limit
  std::shared_ptr<client_lease> request_lease_;  // a trusted proxy's: the current request's client, until answered
  bool idle_ = false;         // waiting for the first bytes of a request
  std::optional<std::uint64_t> idle_key_;  // this connection's entry in context_.state.idle
  std::uint64_t idle_generation_ = 0;      // tells a stale close_if_idle from the current idle period
  std::string encoded_body_;  // a Content-Encoding: gzip upload, compressed
  beast::flat_buffer buffer_;
  std::size_t skipped_empty_line_bytes_ = 0;  // before this request's line (skip_empty_lines)
  std::optional<http::request_parser<http::empty_body>> header_parser_;
  std::optional<http::request_parser<http::buffer_body>> body_parser_;
  std::optional<http::request_parser<http::string_body>> small_parser_;
  std::optional<multipart_parser> multipart_;
  std::vector<char> chunk_;
  std::uint64_t upload_bytes_ = 0;  // body bytes of the current upload received so far
  net::steady_timer rate_timer_;    // the minimum upload rate (arm_rate_check)
  clock::time_point body_started_{};
  bool rate_violated_ = false;      // the current upload fell behind the minimum rate: answer 408
  request_head head_;
  body_plan plan_;
  clock::time_point request_started_{};
  bool busy_ = false;
  bool keep_alive_ = false;  // what the request asked for (HTTP/1.1 default or Connection: keep-alive)
  http::response<http::empty_body> continue_;
  std::optional<http::response<http::span_body<const char>>> response_;
  std::shared_ptr<const std::string> response_body_;
  // An event stream (start_event_stream).
  std::shared_ptr<event_source> events_;
  std::string stream_route_;
  bool chunked_ = false;
  bool stream_ended_ = false;
  std::size_t stream_bytes_ = 0;
  std::string stream_text_;  // the batch being written
  clock::time_point last_event_write_{};
  std::optional<http::response<http::empty_body>> stream_response_;
  std::optional<http::response_serializer<http::empty_body>> stream_serializer_;
  std::optional<net::steady_timer> event_timer_;
};

}  // namespace tracemesh::server::detail
