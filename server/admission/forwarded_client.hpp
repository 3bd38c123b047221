#pragma once
/// @file forwarded_client.hpp
/// Who a request comes from when tracemeshd runs behind a reverse proxy (--trusted-proxy). From a peer inside a
/// trusted range, the client is the rightmost hop of the request's Forwarded header (RFC 7239 §4 and §5.2, for=)
/// — or of X-Forwarded-For when it has no Forwarded field — that is not itself in a trusted range: every hop to
/// its right was added by a proxy we trust, while what lies to its left was sent by the client and may be forged.
/// From any other peer these headers are ignored. A header that cannot be read (bad syntax, a hop that is no IP
/// address, such as "unknown" or an obfuscated name) leaves the peer as the client: a proxy's quota is shared,
/// never a 500 and never a client picked from a guess.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/ip/address.hpp>

#include "core/status.hpp"

namespace tracemesh::server {

/// An IPv4 or IPv6 network: the addresses whose first `prefix_bits` bits equal those of `base`.
struct ip_network {
  boost::asio::ip::address base;  ///< bits past the prefix are zero
  unsigned prefix_bits = 0;

  bool contains(const boost::asio::ip::address& address) const;
  /// "10.0.0.0/8", "fd00::/8".
  std::string to_string() const;
};

/// "10.0.0.0/8", "2001:db8::/32", or a lone address (a /32 or /128); bits past the prefix are cleared.
/// errc::invalid_argument naming the text otherwise.
result<ip_network> parse_network(std::string_view text);

/// Every network of --trusted-proxy values, each one network or a comma-separated list of them.
result<std::vector<ip_network>> parse_networks(const std::vector<std::string>& values);

/// An IP address as text ("192.0.2.1", "2001:db8::1"; IPv4-mapped IPv6 becomes IPv4), or nothing.
std::optional<boost::asio::ip::address> parse_address(std::string_view text);

/// True when `address` (text) lies in one of `networks`.
bool in_networks(const std::vector<ip_network>& networks, std::string_view address);

/// The client of a request whose peer is `peer` (its address as text): see the file comment. `forwarded` and
/// `x_forwarded_for` are the values of every field of that name in the order received.
std::string forwarded_client(const std::string& peer, const std::vector<std::string_view>& forwarded,
                             const std::vector<std::string_view>& x_forwarded_for,
                             const std::vector<ip_network>& trusted);

}  // namespace tracemesh::server
