#pragma once
/// @file detail/quote.hpp
/// Echoing user-supplied text inside error messages safely: bounded length, one line, printable ASCII only.

#include <string>
#include <string_view>

namespace tracemesh::proto::detail {

/// `text` in double quotes, cut to `max_chars` (marked with "..."), with every byte outside printable ASCII
/// (newlines, control bytes, UTF-8) shown as '?', so that an error message stays a single printable line.
inline std::string quoted(std::string_view text, std::size_t max_chars = 32) {
  std::string out = "\"";
  for (std::size_t i = 0; i < text.size() && i < max_chars; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (text.size() > max_chars) out += "...";
  out += '"';
  return out;
}

}  // namespace tracemesh::proto::detail
