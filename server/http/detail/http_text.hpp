#pragma once

#include <cstddef>
#include <string_view>

// The ASCII text helpers of the server's own parsers (headers, multipart parts, token files): one of each.
namespace tracemesh::server::detail {

/// HTTP's optional whitespace (RFC 9110 §5.6.3): what surrounds header values, list elements and parameters.
inline constexpr std::string_view optional_whitespace = " \t";

/// `text` without the leading and trailing characters of `blanks`.
constexpr std::string_view trim(std::string_view text, std::string_view blanks = optional_whitespace) {
  const auto first = text.find_first_not_of(blanks);
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(blanks);
  return text.substr(first, last - first + 1);
}

constexpr char to_lower_ascii(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

/// Case-insensitive equality of ASCII text (header names, codings, parameter names; RFC 9110 §5.1). For
/// std::string_view: boost::beast::iequals, used on Beast's own header values, takes boost::string_view.
constexpr bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (to_lower_ascii(a[i]) != to_lower_ascii(b[i])) return false;
  }
  return true;
}

}  // namespace tracemesh::server::detail
