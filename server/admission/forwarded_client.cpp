#include "server/admission/forwarded_client.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <optional>

#include "server/http/detail/http_text.hpp"

namespace tracemesh::server {

namespace ip = boost::asio::ip;

namespace {

/// The 16 (IPv6) or 4 (IPv4) bytes of an address.
std::array<unsigned char, 16> address_bytes(const ip::address& address, std::size_t& size) {
  std::array<unsigned char, 16> bytes{};
  if (address.is_v4()) {
    const auto v4 = address.to_v4().to_bytes();
    std::copy(v4.begin(), v4.end(), bytes.begin());
    size = v4.size();
  } else {
    bytes = address.to_v6().to_bytes();
    size = bytes.size();
  }
  return bytes;
}

/// `address` with every bit past the first `prefix_bits` cleared.
ip::address masked(const ip::address& address, unsigned prefix_bits) {
  std::size_t size = 0;
  std::array<unsigned char, 16> bytes = address_bytes(address, size);
  for (std::size_t i = 0; i < size; ++i) {
    const unsigned first_bit = static_cast<unsigned>(i) * 8;
    if (first_bit >= prefix_bits) {
      bytes[i] = 0;
    } else if (prefix_bits - first_bit < 8) {
      bytes[i] = static_cast<unsigned char>(bytes[i] & (0xFF << (8 - (prefix_bits - first_bit))));
    }
  }
  if (address.is_v4()) return ip::address_v4(ip::address_v4::bytes_type{bytes[0], bytes[1], bytes[2], bytes[3]});
  return ip::address_v6(bytes);
}

/// Pieces of `text` between `separator`s outside quoted strings (RFC 9110 §5.6.4: backslash escapes one byte);
/// nothing when a quoted string is not closed.
std::optional<std::vector<std::string_view>> split_outside_quotes(std::string_view text, char separator) {
  std::vector<std::string_view> pieces;
  bool quoted = false;
  std::size_t start = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (quoted && text[i] == '\\') {
      ++i;
    } else if (text[i] == '"') {
      quoted = !quoted;
    } else if (!quoted && text[i] == separator) {
      pieces.push_back(text.substr(start, i - start));
      start = i + 1;
    }
  }
  if (quoted) return std::nullopt;
  pieces.push_back(text.substr(start));
  return pieces;
}

/// A token or a quoted string's content (escapes resolved).
std::string unquoted(std::string_view value) {
  if (value.size() < 2 || value.front() != '"' || value.back() != '"') return std::string(value);
  std::string out;
  for (std::size_t i = 1; i + 1 < value.size(); ++i) {
    if (value[i] == '\\' && i + 2 < value.size()) ++i;
    out.push_back(value[i]);
  }
  return out;
}

/// The for= node of one Forwarded element ("for=192.0.2.1;proto=https"), or nothing when it has none.
std::optional<std::string> for_node(std::string_view element) {
  const auto pairs = split_outside_quotes(element, ';');
  if (!pairs) return std::nullopt;
  for (const std::string_view pair : *pairs) {
    const std::string_view trimmed = detail::trim(pair);
    const std::size_t equals = trimmed.find('=');
    if (equals == std::string_view::npos) continue;
    if (detail::iequals(detail::trim(trimmed.substr(0, equals)), "for")) {
      return unquoted(detail::trim(trimmed.substr(equals + 1)));
    }
  }
  return std::nullopt;
}

/// RFC 7239 §6: node-port is a port number (at most 5 digits; here also at most 65535) or an obfuscated "_name".
bool valid_port(std::string_view port) {
  if (!port.empty() && port.front() == '_') return port.size() > 1;
  unsigned number = 0;
  const auto [end, error] = std::from_chars(port.data(), port.data() + port.size(), number);
  return !port.empty() && port.size() <= 5 && error == std::errc{} && end == port.data() + port.size() &&
         number <= 65535;
}

/// The address of a node: "192.0.2.1", "192.0.2.1:4711", "[2001:db8::1]", "[2001:db8::1]:4711", or a bare IPv6
/// address (X-Forwarded-For's form). Nothing for "unknown", obfuscated names and anything malformed.
std::optional<ip::address> node_address(std::string_view node) {
  node = detail::trim(node);
  if (!node.empty() && node.front() == '[') {
    const std::size_t close = node.find(']');
    if (close == std::string_view::npos) return std::nullopt;
    const std::string_view rest = node.substr(close + 1);
    if (!rest.empty() && !(rest.front() == ':' && valid_port(rest.substr(1)))) return std::nullopt;
    const auto address = parse_address(node.substr(1, close - 1));
    return address && address->is_v6() ? address : std::nullopt;
  }
  const std::size_t colons = static_cast<std::size_t>(std::count(node.begin(), node.end(), ':'));
  if (colons == 1) {
    const std::size_t colon = node.find(':');
    if (!valid_port(node.substr(colon + 1))) return std::nullopt;
    const auto address = parse_address(node.substr(0, colon));
    return address && address->is_v4() ? address : std::nullopt;
  }
  return parse_address(node);
}

/// The hops a header names, left (the client's end) to right (the nearest proxy); an empty optional for a hop
/// that cannot be read. Nothing when the header's syntax is broken.
std::optional<std::vector<std::optional<std::string>>> hops_of(const std::vector<std::string_view>& forwarded,
                                                               const std::vector<std::string_view>& x_forwarded_for) {
  std::vector<std::optional<std::string>> hops;
  const bool standard = !forwarded.empty();
  for (const std::string_view field : standard ? forwarded : x_forwarded_for) {
    const auto elements = split_outside_quotes(field, ',');
    if (!elements) return std::nullopt;
    for (const std::string_view element : *elements) {
      if (standard) {
        hops.push_back(for_node(element));
      } else {
        hops.emplace_back(std::string(detail::trim(element)));
      }
    }
  }
  return hops;
}

bool in_any(const std::vector<ip_network>& networks, const ip::address& address) {
  return std::any_of(networks.begin(), networks.end(), [&](const ip_network& n) { return n.contains(address); });
}

}  // namespace

bool ip_network::contains(const ip::address& address) const {
  return address.is_v4() == base.is_v4() && masked(address, prefix_bits) == base;
}

std::string ip_network::to_string() const { return base.to_string() + "/" + std::to_string(prefix_bits); }

std::optional<ip::address> parse_address(std::string_view text) {
  boost::system::error_code ec;
  const ip::address address = ip::make_address(std::string(text), ec);
  if (ec || text.find('%') != std::string_view::npos) return std::nullopt;  // no zone ids: no interface names
  if (address.is_v6() && address.to_v6().is_v4_mapped()) {
    return ip::address(ip::make_address_v4(ip::v4_mapped, address.to_v6()));
  }
  return address;
}

result<ip_network> parse_network(std::string_view text) {
  const std::string_view trimmed = detail::trim(text);
  const std::size_t slash = trimmed.find('/');
  const auto address = parse_address(trimmed.substr(0, slash));
  const auto invalid = [&] {
    std::string message(1, '\'');  // appended, not operator+: GCC 12 warns falsely (-Wrestrict) on "'" + string
    message.append(text).append("' is not an IPv4 or IPv6 address or network (CIDR, e.g. 10.0.0.0/8)");
    return status(errc::invalid_argument, std::move(message));
  };
  if (!address) return invalid();
  const unsigned width = address->is_v4() ? 32 : 128;
  unsigned prefix = width;
  if (slash != std::string_view::npos) {
    const std::string_view digits = trimmed.substr(slash + 1);
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), prefix);
    if (digits.empty() || error != std::errc{} || end != digits.data() + digits.size() || prefix > width) {
      return invalid();
    }
  }
  return ip_network{masked(*address, prefix), prefix};
}

result<std::vector<ip_network>> parse_networks(const std::vector<std::string>& values) {
  std::vector<ip_network> networks;
  for (const std::string& value : values) {
    const std::optional<std::vector<std::string_view>> pieces = split_outside_quotes(value, ',');
    if (!pieces) return parse_network(value).error();  // an unclosed quote: not a network either
    for (const std::string_view piece : *pieces) {
      if (detail::trim(piece).empty()) continue;
      result<ip_network> network = parse_network(piece);
      if (!network.ok()) return network.error();
      networks.push_back(*network);
    }
  }
  return networks;
}

bool in_networks(const std::vector<ip_network>& networks, std::string_view address) {
  const auto parsed = parse_address(address);
  return parsed && in_any(networks, *parsed);
}

std::string forwarded_client(const std::string& peer, const std::vector<std::string_view>& forwarded,
                             const std::vector<std::string_view>& x_forwarded_for,
                             const std::vector<ip_network>& trusted) {
  if (!in_networks(trusted, peer)) return peer;
  const auto hops = hops_of(forwarded, x_forwarded_for);
  if (!hops || hops->empty()) return peer;
  std::string leftmost = peer;
  for (auto hop = hops->rbegin(); hop != hops->rend(); ++hop) {
    const std::optional<ip::address> address = *hop ? node_address(**hop) : std::nullopt;
    if (!address) return peer;
    if (!in_any(trusted, *address)) return address->to_string();
    leftmost = address->to_string();
  }
  return leftmost;  // every hop is a trusted proxy: the farthest one named is the best we know
}

}  // namespace tracemesh::server
