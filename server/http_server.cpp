#include "server/http_server.hpp"

#include <chrono>
#include <limits>
#include <optional>
#include <utility>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "proto/api_types.hpp"
#include "server/logging.hpp"

namespace tracemesh::server {

namespace beast = boost::beast;
using tcp = net::ip::tcp;
using clock = std::chrono::steady_clock;

reply error_reply(unsigned status, std::string_view code, std::string_view message, std::string route) {
  return json_reply(status, proto::error_body(code, message).dump(), std::move(route));
}

reply json_reply(unsigned status, std::string body, std::string route) {
  reply out;
  out.status = status;
  out.route = std::move(route);
  out.body = std::make_shared<const std::string>(std::move(body));
  return out;
}

namespace {

/// Bytes read from the socket per body read: the multipart parser sees the upload in pieces of at most this.
constexpr std::size_t body_chunk_bytes = 64 * 1024;

/// The route label used for requests rejected before routing.
constexpr const char* unrouted = "(unrouted)";

bool expects_continue(const request_head& head) {
  const auto expect = head[http::field::expect];
  return beast::iequals(expect, "100-continue");
}

/// One connection. Lives as long as an operation or a pending reply holds a shared_ptr to it.
class session : public std::enable_shared_from_this<session> {
 public:
  session(tcp::socket&& socket, http_context& context) : stream_(std::move(socket)), context_(context) {
    context_.state.open_connections.fetch_add(1, std::memory_order_relaxed);
  }
  ~session() { context_.state.open_connections.fetch_sub(1, std::memory_order_relaxed); }

  void run() {
    net::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->read_header(); });
  }

  /// Over the connection limit: answer 503 and close without reading.
  void refuse() {
    net::dispatch(stream_.get_executor(), [self = shared_from_this()] {
      reply busy = error_reply(503, "unavailable", "too many connections", unrouted);
      busy.headers.emplace_back("Retry-After", std::to_string(self->context_.limits.retry_after_seconds));
      busy.close = true;
      self->head_.version(11);
      self->send(std::move(busy));
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
    stream_.expires_after(context_.limits.header_timeout);
    http::async_read_header(stream_, buffer_, *header_parser_,
                            beast::bind_front_handler(&session::on_header, shared_from_this()));
  }

  void on_header(beast::error_code ec, std::size_t) {
    if (ec) return on_header_error(ec);
    begin_request();
    head_ = header_parser_->get().base();
    keep_alive_ = header_parser_->keep_alive();
    std::variant<reply, body_plan> decision = context_.handler.plan(head_);
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
    begin_request();
    head_.version(11);
    if (ec == http::error::header_limit) {
      return send(error_reply(431, "header_too_large",
                              "the request header exceeds " + std::to_string(context_.limits.max_header_bytes) +
                                  " bytes",
                              unrouted),
                  /*force_close=*/true);
    }
    if (ec == http::error::partial_message) return close();
    send(error_reply(400, "bad_request", "malformed HTTP request: " + ec.message(), unrouted), true);
  }

  void begin_request() {
    if (!busy_) context_.state.busy_requests.fetch_add(1, std::memory_order_relaxed);
    busy_ = true;
    request_started_ = clock::now();
  }

  void send_continue() {
    continue_ = http::response<http::empty_body>{http::status::continue_, head_.version()};
    stream_.expires_after(context_.limits.write_timeout);
    http::async_write(stream_, continue_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->close();
      self->read_body();
    });
  }

  // ---- reading the body --------------------------------------------------------------------------------------

  void read_body() {
    header_parser_->body_limit(plan_.max_bytes);
    if (plan_.upload) {
      body_parser_.emplace(std::move(*header_parser_));
      multipart_.emplace(plan_.boundary, plan_.part_limits);
      chunk_.resize(body_chunk_bytes);
      return read_upload_chunk();
    }
    small_parser_.emplace(std::move(*header_parser_));
    stream_.expires_at(request_started_ + context_.limits.request_timeout);
    http::async_read(stream_, buffer_, *small_parser_,
                     beast::bind_front_handler(&session::on_small_body, shared_from_this()));
  }

  void on_small_body(beast::error_code ec, std::size_t) {
    if (ec) return on_body_error(ec);
    stream_.expires_never();
    context_.handler.handle(head_, plan_, std::move(small_parser_->get().body()), make_sink());
  }

  void read_upload_chunk() {
    auto& body = body_parser_->get().body();
    body.data = chunk_.data();
    body.size = chunk_.size();
    stream_.expires_at(request_started_ + context_.limits.request_timeout);
    http::async_read_some(stream_, buffer_, *body_parser_,
                          beast::bind_front_handler(&session::on_upload_chunk, shared_from_this()));
  }

  void on_upload_chunk(beast::error_code ec, std::size_t) {
    if (ec == http::error::need_buffer) ec = {};
    if (ec) return on_body_error(ec);
    const std::size_t received = chunk_.size() - body_parser_->get().body().size;
    const status fed = multipart_->feed(std::string_view(chunk_.data(), received));
    if (!fed.ok()) return reject_upload(fed);
    if (!body_parser_->is_done()) return read_upload_chunk();
    const status finished = multipart_->finish();
    if (!finished.ok()) return reject_upload(finished);
    stream_.expires_never();
    std::vector<multipart_part> parts = std::move(multipart_->parts());
    multipart_.reset();
    chunk_ = {};
    context_.handler.handle_upload(head_, std::move(plan_), std::move(parts), make_sink());
  }

  void body_complete_without_bytes() {
    stream_.expires_never();
    if (!plan_.upload) return context_.handler.handle(head_, plan_, std::string(), make_sink());
    reject_upload(status(errc::invalid_input, "the request has no body: expected a multipart/form-data upload"));
  }

  void reject_upload(const status& error) {
    const bool too_large = error.code() == errc::limit_exceeded;
    send(error_reply(too_large ? 413 : 400, errc_name(error.code()), error.message(), plan_.route),
         /*force_close=*/!parser_done());
  }

  void on_body_error(beast::error_code ec) {
    if (ec == http::error::body_limit) {
      return send(error_reply(413, "limit_exceeded",
                              "the request body exceeds " + std::to_string(plan_.max_bytes) + " bytes",
                              plan_.route),
                  true);
    }
    if (ec == beast::error::timeout || ec == http::error::partial_message || ec == net::error::eof ||
        ec == net::error::connection_reset || ec == http::error::end_of_stream) {
      log_event(context_.log, spdlog::level::info, "request_aborted",
                {{"route", plan_.route}, {"reason", ec.message()}});
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

  /// A reply_sink that hands the reply back to this session's strand, from whatever thread calls it. dispatch:
  /// a handler answering at once (a memory cache hit) runs send() inline; a worker or prep thread queues it.
  reply_sink make_sink() {
    return [self = shared_from_this()](reply r) {
      net::dispatch(self->stream_.get_executor(),
                    [self, r = std::move(r)]() mutable { self->send(std::move(r)); });
    };
  }

  void send(reply r, bool force_close = false) {
    const bool head_request = head_.method() == http::verb::head;
    const bool keep_alive =
        !force_close && !r.close && keep_alive_ && !context_.state.draining.load(std::memory_order_relaxed);
    response_body_ = r.body ? r.body : std::make_shared<const std::string>();
    response_.emplace(static_cast<http::status>(r.status), head_.version() == 10 ? 10 : 11);
    response_->set(http::field::server, "tracemeshd");
    if (r.status != 204 && r.status != 304) response_->set(http::field::content_type, r.content_type);
    const std::string origin(head_[http::field::origin]);
    context_.cors.add_response_headers(origin, r.headers);
    for (const auto& [name, value] : r.headers) response_->insert(name, value);
    if (head_request || r.status == 204 || r.status == 304) {
      response_->body() = {};
    } else {
      response_->body() = http::span_body<const char>::value_type(response_body_->data(), response_body_->size());
    }
    response_->keep_alive(keep_alive);
    if (r.status != 204 && r.status != 304) response_->content_length(response_body_->size());
    context_.stats.count_request(r.route, r.status);
    if (r.status >= 400) {
      log_event(context_.log, spdlog::level::info, "request",
                {{"method", std::string(head_.method_string())},
                 {"route", r.route},
                 {"status", r.status},
                 {"bytes", response_body_->size()},
                 {"ms", std::chrono::duration<double, std::milli>(clock::now() - request_started_).count()}});
    }
    stream_.expires_after(context_.limits.write_timeout);
    http::async_write(stream_, *response_,
                      [self = shared_from_this(), keep_alive](beast::error_code ec, std::size_t) {
                        self->on_write(ec, keep_alive);
                      });
  }

  void on_write(beast::error_code ec, bool keep_alive) {
    end_request();
    response_.reset();
    response_body_.reset();
    if (ec || !keep_alive) return close();
    read_header();
  }

  void end_request() {
    if (busy_) context_.state.busy_requests.fetch_sub(1, std::memory_order_relaxed);
    busy_ = false;
  }

  void close() {
    end_request();
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.close();
  }

  beast::tcp_stream stream_;
  http_context& context_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> header_parser_;
  std::optional<http::request_parser<http::buffer_body>> body_parser_;
  std::optional<http::request_parser<http::string_body>> small_parser_;
  std::optional<multipart_parser> multipart_;
  std::vector<char> chunk_;
  request_head head_;
  body_plan plan_;
  clock::time_point request_started_{};
  bool busy_ = false;
  bool keep_alive_ = false;  // what the request asked for (HTTP/1.1 default or Connection: keep-alive)
  http::response<http::empty_body> continue_;
  std::optional<http::response<http::span_body<const char>>> response_;
  std::shared_ptr<const std::string> response_body_;
};

}  // namespace

http_listener::http_listener(net::io_context& io, http_context& context)
    : io_(io), context_(context), strand_(net::make_strand(io)), acceptor_(strand_) {}

status http_listener::open(const std::string& host, unsigned short port) {
  beast::error_code ec;
  const auto address = net::ip::make_address(host, ec);
  if (ec) return status(errc::invalid_argument, "invalid listen address '" + host + "': " + ec.message());
  const tcp::endpoint endpoint(address, port);
  const std::string where = host + ":" + std::to_string(port);
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(net::socket_base::max_listen_connections, ec);
  if (ec) return status(errc::io_error, "cannot listen on " + where + ": " + ec.message());
  port_ = acceptor_.local_endpoint(ec).port();
  return status::success();
}

void http_listener::run() {
  net::dispatch(strand_, [self = shared_from_this()] { self->do_accept(); });
}

void http_listener::stop() {
  net::post(strand_, [self = shared_from_this()] {
    beast::error_code ignored;
    self->acceptor_.close(ignored);
  });
}

void http_listener::do_accept() {
  if (!acceptor_.is_open()) return;
  acceptor_.async_accept(net::make_strand(io_), beast::bind_front_handler(&http_listener::on_accept,
                                                                          shared_from_this()));
}

void http_listener::on_accept(boost::system::error_code ec, tcp::socket socket) {
  if (ec == net::error::operation_aborted || !acceptor_.is_open()) return;
  if (!ec) {
    auto connection = std::make_shared<session>(std::move(socket), context_);
    // The new session already counts itself: more than the limit means this one is over it.
    if (context_.state.open_connections.load(std::memory_order_relaxed) > context_.limits.max_connections) {
      connection->refuse();
    } else {
      connection->run();
    }
  } else {
    log_event(context_.log, spdlog::level::warn, "accept_failed", {{"error", ec.message()}});
  }
  do_accept();
}

}  // namespace tracemesh::server
