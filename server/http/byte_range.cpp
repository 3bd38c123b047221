#include "server/http/byte_range.hpp"

#include <limits>

#include "server/http/detail/http_text.hpp"

namespace tracemesh::server {
namespace {

using detail::trim;

/// 1DIGIT+ as a number; nullopt for anything else or past 2^64 - 1.
std::optional<std::uint64_t> parse_number(std::string_view text) {
  if (text.empty()) return std::nullopt;
  std::uint64_t value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    const auto digit = static_cast<std::uint64_t>(c - '0');
    if (value > (std::numeric_limits<std::uint64_t>::max() - digit) / 10) return std::nullopt;
    value = value * 10 + digit;
  }
  return value;
}

/// One range-spec against `size`; nullopt when it does not parse (the whole field is then ignored).
std::optional<range_decision> parse_spec(std::string_view spec, std::uint64_t size) {
  const auto dash = spec.find('-');
  if (dash == std::string_view::npos) return std::nullopt;
  const std::string_view first_text = spec.substr(0, dash);
  const std::string_view last_text = spec.substr(dash + 1);
  if (first_text.empty()) {  // suffix: the last n bytes
    const std::optional<std::uint64_t> n = parse_number(last_text);
    if (!n) return std::nullopt;
    if (*n == 0 || size == 0) return range_decision{range_outcome::unsatisfiable, {}};
    const std::uint64_t length = std::min(*n, size);
    return range_decision{range_outcome::partial, {size - length, length}};
  }
  const std::optional<std::uint64_t> first = parse_number(first_text);
  if (!first) return std::nullopt;
  std::uint64_t last = size == 0 ? 0 : size - 1;
  if (!last_text.empty()) {
    const std::optional<std::uint64_t> given = parse_number(last_text);
    if (!given || *given < *first) return std::nullopt;  // "5-3" is invalid syntax (RFC 9110 §14.1.1)
    last = std::min(last, *given);
  }
  if (*first >= size) return range_decision{range_outcome::unsatisfiable, {}};
  return range_decision{range_outcome::partial, {*first, last - *first + 1}};
}

bool if_range_matches(std::optional<std::string_view> if_range, std::string_view etag) {
  if (!if_range) return true;
  // Strong comparison: a weak tag never matches, nor a date (no Last-Modified is sent).
  return trim(*if_range) == etag && !etag.starts_with("W/");
}

}  // namespace

range_decision decide_range(std::optional<std::string_view> range, std::optional<std::string_view> if_range,
                            std::string_view etag, std::uint64_t size) {
  if (!range || !if_range_matches(if_range, etag)) return {};
  const std::string_view field = trim(*range);
  constexpr std::string_view unit = "bytes=";
  if (field.size() < unit.size()) return {};
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const char c = field[i] >= 'A' && field[i] <= 'Z' ? static_cast<char>(field[i] - 'A' + 'a') : field[i];
    if (c != unit[i]) return {};
  }
  const std::string_view specs = field.substr(unit.size());
  if (specs.find(',') != std::string_view::npos) return {};  // several ranges: the whole representation
  return parse_spec(trim(specs), size).value_or(range_decision{});
}

std::string content_range(const range_decision& decision, std::uint64_t size) {
  if (decision.outcome != range_outcome::partial) return "bytes */" + std::to_string(size);
  return "bytes " + std::to_string(decision.range.first) + "-" +
         std::to_string(decision.range.first + decision.range.length - 1) + "/" + std::to_string(size);
}

}  // namespace tracemesh::server
