#include "server/http_server.hpp"

#include <utility>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>

#include "proto/api_types.hpp"
#include "server/detail/http_session.hpp"
#include "server/logging.hpp"

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

reply json_reply(unsigned status, std::string body, std::string route) {
  reply out;
  out.status = status;
  out.route = std::move(route);
  out.body = std::make_shared<const std::string>(std::move(body));
  return out;
}

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
    auto connection = std::make_shared<tcp_session>(beast::tcp_stream(std::move(socket)), context_);
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
