#include "core/io/text_lines.hpp"

#include <algorithm>

#include "core/io/pqr_text.hpp"

namespace tracemesh::detail {

namespace {

constexpr std::string_view utf8_bom = "\xEF\xBB\xBF";

bool is_line_terminator(char c) { return c == '\n' || c == '\r'; }

/// Two lower-case hex digits of `c`.
std::string hex_byte(unsigned char c) {
  static constexpr char digits[] = "0123456789abcdef";
  return {digits[c >> 4], digits[c & 0xF]};
}

/// Offset just past the terminator at `end`: "\r\n" is one terminator, a bare "\r" or "\n" another.
std::size_t skip_line_terminator(std::string_view text, std::size_t end) {
  if (end >= text.size()) return end;
  if (text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n') return end + 2;
  return end + 1;
}

}  // namespace

status line_error(std::size_t line_number, const std::string& what) {
  return {errc::invalid_input, "line " + std::to_string(line_number) + ": " + what};
}

text_lines::text_lines(std::string_view text, std::size_t max_line_bytes, std::string_view format)
    : text_(text), max_line_bytes_(max_line_bytes), format_(format) {
  utf16_ = text_.substr(0, 2) == "\xFF\xFE" || text_.substr(0, 2) == "\xFE\xFF";
  if (text_.substr(0, utf8_bom.size()) == utf8_bom) text_.remove_prefix(utf8_bom.size());
}

result<bool> text_lines::next(std::string_view& line) {
  if (utf16_) return line_error(1, "UTF-16 byte order mark: " + format_ + " must be ASCII or UTF-8 text");
  if (begin_ >= text_.size()) return false;
  ++line_number_;
  std::size_t end = 0;
  if (status scanned = find_line_end(begin_, end); !scanned) return scanned;
  line = text_.substr(begin_, end - begin_);
  begin_ = skip_line_terminator(text_, end);
  return true;
}

status text_lines::find_line_end(std::size_t begin, std::size_t& end) const {
  const std::size_t scan_end = begin + std::min(max_line_bytes_, text_.size() - begin);
  bool non_ascii = false;
  std::size_t i = begin;
  for (; i < scan_end; ++i) {
    const auto c = static_cast<unsigned char>(text_[i]);
    if (c >= 0x20 && c < 0x7F) continue;  // printable ASCII: almost every byte
    if (is_line_terminator(static_cast<char>(c))) break;
    if (c == '\t') continue;
    if (c >= 0x80) {
      non_ascii = true;
      continue;
    }
    return line_error(line_number_, "control byte 0x" + hex_byte(c) + " at column " + std::to_string(i - begin + 1) +
                                        " (binary data, not " + format_ + " text)");
  }
  if (i == scan_end && i < text_.size() && !is_line_terminator(text_[i])) {
    return line_error(line_number_,
                      "longer than " + std::to_string(max_line_bytes_) + " bytes (limits.max_line_bytes)");
  }
  end = i;
  if (non_ascii) return check_utf8(text_.substr(begin, end - begin));
  return status::success();
}

status text_lines::check_utf8(std::string_view line) const {
  const std::size_t bad = find_invalid_utf8(line);
  if (bad == std::string_view::npos) return status::success();
  return line_error(line_number_, "byte 0x" + hex_byte(static_cast<unsigned char>(line[bad])) + " at column " +
                                      std::to_string(bad + 1) + " is not UTF-8 (binary data, not " + format_ +
                                      " text)");
}

std::string_view trimmed(std::string_view text) {
  const std::size_t begin = text.find_first_not_of(" \t");
  if (begin == std::string_view::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t") - begin + 1);
}

bool has_record_prefix(std::string_view line, std::string_view prefix) {
  if (line.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    const char c = line[i];
    if ((c >= 'a' && c <= 'z' ? static_cast<char>(c - 'a' + 'A') : c) != prefix[i]) return false;
  }
  return true;
}

}  // namespace tracemesh::detail
