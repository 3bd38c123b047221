#include "server/redis/redis_url.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>

namespace tracemesh::server {

namespace {

constexpr std::string_view scheme = "redis://";

// Messages are built with append: GCC 12 warns falsely (-Wrestrict) on "literal" + std::string chains here.
status bad_url(std::string_view url, std::string_view why) {
  std::string message = "bad Redis URL '";
  message.append(url).append("': ").append(why).append(" (expected redis://HOST:PORT[/DB])");
  return status(errc::invalid_argument, std::move(message));
}

/// bad_url naming the offending part: "'<part>' <why>".
status bad_part(std::string_view url, std::string_view what, std::string_view part, std::string_view why) {
  std::string message(what);
  message.append(" '").append(part).append("' ").append(why);
  return bad_url(url, message);
}

/// A decimal number without sign or leading '+', at most `max`; nullopt otherwise.
std::optional<unsigned> parse_decimal(std::string_view text, unsigned max) {
  unsigned value = 0;
  const char* last = text.data() + text.size();
  const auto [end, error] = std::from_chars(text.data(), last, value);
  if (text.empty() || error != std::errc{} || end != last || value > max) return std::nullopt;
  return value;
}

bool is_host_name(std::string_view host) {
  const auto allowed = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-'; };
  return !host.empty() && host.size() <= 253 && std::all_of(host.begin(), host.end(), allowed) &&
         host.front() != '.' && host.front() != '-' && host.back() != '.' && host.back() != '-';
}

bool is_ipv6_text(std::string_view host) {
  const auto allowed = [](char c) { return std::isxdigit(static_cast<unsigned char>(c)) || c == ':' || c == '.'; };
  return host.size() >= 2 && host.find(':') != std::string_view::npos &&
         std::all_of(host.begin(), host.end(), allowed);
}

}  // namespace

std::string redis_endpoint::to_url() const {
  const bool ipv6 = host.find(':') != std::string::npos;
  std::string url(scheme);
  if (ipv6) url.append("[").append(host).append("]");
  else url.append(host);
  url.append(":").append(std::to_string(port)).append("/").append(std::to_string(db));
  return url;
}

result<redis_endpoint> parse_redis_url(std::string_view url) {
  if (url.substr(0, scheme.size()) != scheme) {
    if (url.substr(0, 9) == "rediss://") return bad_url(url, "TLS (rediss://) is not supported");
    return bad_url(url, "it must start with redis://");
  }
  std::string_view rest = url.substr(scheme.size());
  if (rest.find_first_of("?#") != std::string_view::npos) return bad_url(url, "query and fragment are not supported");
  if (rest.find('@') != std::string_view::npos) return bad_url(url, "user and password are not supported");

  redis_endpoint endpoint;
  const auto slash = rest.find('/');
  std::string_view authority = rest.substr(0, slash);
  if (slash != std::string_view::npos && slash + 1 < rest.size()) {  // "redis://h:1/" is database 0
    const std::string_view db_text = rest.substr(slash + 1);
    const auto db = parse_decimal(db_text, max_redis_db_index);
    if (!db) {
      return bad_part(url, "database", db_text, "is not an index 0.." + std::to_string(max_redis_db_index));
    }
    endpoint.db = *db;
  }

  std::string_view host = authority;
  std::optional<std::string_view> port_text;
  if (!authority.empty() && authority.front() == '[') {
    const auto close = authority.find(']');
    if (close == std::string_view::npos) return bad_url(url, "'[' without ']'");
    host = authority.substr(1, close - 1);
    const std::string_view after = authority.substr(close + 1);
    if (!after.empty()) {
      if (after.front() != ':') return bad_url(url, "unexpected text after ']'");
      port_text = after.substr(1);
    }
    if (!is_ipv6_text(host)) return bad_part(url, "host", host, "is not an IPv6 address");
  } else {
    const auto colon = authority.find(':');
    if (colon != std::string_view::npos) {
      host = authority.substr(0, colon);
      port_text = authority.substr(colon + 1);
    }
    if (host.empty()) return bad_url(url, "no host");
    if (!is_host_name(host)) return bad_part(url, "host", host, "is not a host name or address");
  }
  if (port_text) {
    const auto port = parse_decimal(*port_text, 65535);
    if (!port || *port == 0) return bad_part(url, "port", *port_text, "is not 1..65535");
    endpoint.port = static_cast<std::uint16_t>(*port);
  }
  endpoint.host = std::string(host);
  return endpoint;
}

}  // namespace tracemesh::server
