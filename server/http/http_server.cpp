#include "server/http/http_server.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <random>
#include <utility>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/range/iterator_range.hpp>

#include "proto/api_types.hpp"
#include "server/http/detail/http_session.hpp"
#include "server/observability/logging.hpp"

namespace tracemesh::server {

namespace beast = boost::beast;
using tcp = net::ip::tcp;
using tcp_session = detail::http_session<beast::tcp_stream>;

reply error_reply(unsigned status, std::string_view code, std::string_view message, std::string route) {
  // Messages may quote client bytes (a parameter name, a PQR field): invalid UTF-8 is replaced (U+FFFD), never
  // thrown — an exception here would escape an I/O handler and end the process.
  const std::string body =
      proto::error_body(code, message).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return json_reply(status, body, std::move(route));
}

std::optional<std::string> accept_encoding(const request_head& head) {
  std::optional<std::string> joined;
  for (const auto& field : boost::make_iterator_range(head.equal_range(http::field::accept_encoding))) {
    if (joined) {
      joined->push_back(',');
    } else {
      joined.emplace();
    }
    joined->append(to_std(field.value()));
  }
  return joined;
}

reply json_reply(unsigned status, std::string body, std::string route) {
  reply out;
  out.status = status;
  out.route = std::move(route);
  out.body = std::make_shared<const std::string>(std::move(body));
  out.compressible = true;
  return out;
}

std::uint64_t idle_connections::add(std::function<void()> close) {
  std::lock_guard lock(mutex_);
  const std::uint64_t key = next_key_++;
  idle_.emplace(key, std::move(close));
  return key;
}

void idle_connections::remove(std::uint64_t key) {
  std::lock_guard lock(mutex_);
  idle_.erase(key);
}

bool idle_connections::close_oldest() {
  std::function<void()> close;
  {
    std::lock_guard lock(mutex_);
    if (idle_.empty()) return false;
    close = std::move(idle_.begin()->second);
    idle_.erase(idle_.begin());
  }
  close();
  return true;
}

std::size_t idle_connections::size() const {
  std::lock_guard lock(mutex_);
  return idle_.size();
}

reply client_limit_reply(std::string_view limit_name, std::size_t limit, std::string_view what,
                         unsigned retry_after_seconds, std::string route) {
  reply r = error_reply(429, "client_limit",
                        "this client already has " + std::to_string(limit) + " " + std::string(what) + " (" +
                            std::string(limit_name) + "); retry later",
                        std::move(route));
  r.headers.emplace_back("Retry-After", std::to_string(retry_after_seconds));
  return r;
}

reply client_connection_limit_reply(const server_limits& limits) {
  reply r = client_limit_reply("max_connections_per_client", limits.max_connections_per_client, "open connections",
                               limits.retry_after_seconds, detail::unrouted_route);
  r.close = true;
  return r;
}

namespace {

/// splitmix64's finaliser: a bijection on 64-bit integers, so distinct counters give distinct ids.
std::uint64_t mix(std::uint64_t x) {
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

request_id_source::request_id_source() : seed_(std::random_device{}()) {
  seed_ = (seed_ << 32) ^ std::random_device{}();
}

std::string request_id_source::next() {
  const std::uint64_t value = mix(seed_ + counter_.fetch_add(1, std::memory_order_relaxed));
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

bool request_id_source::acceptable(std::string_view id) {
  if (id.empty() || id.size() > 128) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == ':';
  });
}

http_listener::http_listener(net::io_context& io, http_context& context)
    : io_(io), context_(context), strand_(net::make_strand(io)), acceptor_(strand_), accept_retry_(strand_) {}

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
    self->accept_retry_.cancel();
  });
}

void http_listener::do_accept() {
  if (!acceptor_.is_open()) return;
  acceptor_.async_accept(net::make_strand(io_), beast::bind_front_handler(&http_listener::on_accept,
                                                                          shared_from_this()));
}

void http_listener::on_accept(boost::system::error_code ec, tcp::socket socket) {
  if (ec == net::error::operation_aborted || !acceptor_.is_open()) return;
  if (ec) {
    // Out of descriptors (EMFILE, ENFILE) or a transient error: the connection waits in the backlog; retrying at
    // once would spin on the same error.
    log_event(context_.log, spdlog::level::warn, "accept_failed", {{"error", ec.message()}});
    accept_retry_.expires_after(context_.limits.accept_error_pause);
    accept_retry_.async_wait([self = shared_from_this()](boost::system::error_code wait_error) {
      if (!wait_error) self->do_accept();
    });
    return;
  }
  beast::error_code address_error;
  const tcp::endpoint peer = socket.remote_endpoint(address_error);
  const std::string client = address_error ? std::string() : peer.address().to_string();
  admit(std::make_shared<tcp_session>(beast::tcp_stream(std::move(socket)), context_), client);
  do_accept();
}

template <class Session>
void http_listener::admit(const std::shared_ptr<Session>& connection, const std::string& client) {
  http_server_state& state = context_.state;
  const server_limits& limits = context_.limits;
  // A trusted proxy's connection is counted against the client of each request it carries, once its header is
  // read; anyone else's against its address, now.
  const bool proxied = connection->from_trusted_proxy();
  std::shared_ptr<client_lease> lease = proxied ? nullptr : state.client_connections.acquire(client);
  if (proxied || lease) {
    // The new session already counts itself: more than the limit means this one is over it. An idle keep-alive
    // connection gives way first (it closes on its own strand, soon).
    const std::size_t open = state.open_connections.load(std::memory_order_relaxed);
    const std::size_t probes = state.probe_connections.load(std::memory_order_relaxed);
    if (open - std::min(open, probes) <= limits.max_connections || state.idle.close_oldest()) {
      connection->hold(std::move(lease));
      return connection->run();
    }
  }
  reply refusal = proxied || lease ? Session::too_many_connections(limits.retry_after_seconds)
                                   : client_connection_limit_reply(limits);
  // A probe; when the reserve is full, the oldest probe that has sent nothing gives way to this newer one.
  if (state.probe_connections.load(std::memory_order_relaxed) < limits.health_connection_reserve ||
      state.probes.close_oldest()) {
    return connection->run_probe(std::move(refusal));
  }
  connection->refuse();
}

}  // namespace tracemesh::server
