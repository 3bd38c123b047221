#include "core/io/pqr_text.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

namespace tracemesh::detail {

namespace {

bool is_printable_ascii(unsigned char c) { return c >= 0x20 && c < 0x7F; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_field_separator(char c) { return c == ' ' || c == '\t'; }

void append_hex_escape(std::string& out, unsigned char c) {
  static constexpr char hex_digits[] = "0123456789abcdef";
  out += "\\x";
  out += hex_digits[c >> 4];
  out += hex_digits[c & 0xF];
}

/// Splits the last piece off `field`: the part from the last '-' that follows a digit, or the whole field.
std::string_view pop_last_piece(std::string_view& field) {
  for (std::size_t i = field.size(); i-- > 1;) {
    if (field[i] == '-' && is_digit(field[i - 1])) {
      const std::string_view piece = field.substr(i);
      field = field.substr(0, i);
      return piece;
    }
  }
  const std::string_view piece = field;
  field = {};
  return piece;
}

/// Removes and returns the last whitespace-separated field of `text` (empty when none is left).
std::string_view pop_last_field(std::string_view& text) {
  std::size_t end = text.size();
  while (end > 0 && is_field_separator(text[end - 1])) --end;
  std::size_t begin = end;
  while (begin > 0 && !is_field_separator(text[begin - 1])) --begin;
  const std::string_view field = text.substr(begin, end - begin);
  text = text.substr(0, begin);
  return field;
}

/// Length of the UTF-8 sequence starting at bytes[i] when it is well-formed, else 0 (Unicode Table 3-7).
std::size_t utf8_sequence_length(std::string_view bytes, std::size_t i) {
  const auto byte_at = [&](std::size_t k) { return static_cast<unsigned char>(bytes[k]); };
  const unsigned char lead = byte_at(i);
  std::size_t length = 0;
  unsigned char second_lo = 0x80, second_hi = 0xBF;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) second_lo = 0xA0;  // overlong
    if (lead == 0xED) second_hi = 0x9F;  // surrogates
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) second_lo = 0x90;  // overlong
    if (lead == 0xF4) second_hi = 0x8F;  // above U+10FFFF
  } else {
    return 0;
  }
  if (bytes.size() - i < length) return 0;
  if (byte_at(i + 1) < second_lo || byte_at(i + 1) > second_hi) return 0;
  for (std::size_t k = 2; k < length; ++k) {
    if (byte_at(i + k) < 0x80 || byte_at(i + k) > 0xBF) return 0;
  }
  return length;
}

}  // namespace

std::string quote_bytes(std::string_view bytes, std::size_t max_bytes) {
  const bool cut = bytes.size() > max_bytes;
  if (cut) bytes = bytes.substr(0, max_bytes);
  std::string out;
  out.reserve(bytes.size() + 3);
  for (const char ch : bytes) {
    const auto c = static_cast<unsigned char>(ch);
    if (is_printable_ascii(c) && c != '\\') {
      out += ch;
    } else {
      append_hex_escape(out, c);
    }
  }
  if (cut) out += "...";
  return out;
}

std::string format_number(double value) {
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  if (ec != std::errc{}) return "?";  // cannot happen: 32 bytes hold any double
  return std::string(buffer, end);
}

parsed_number parse_number(std::string_view field) {
  // from_chars rejects a leading '+'; accept "+1.5" but not "+-1.5" or "++1".
  if (field.size() > 1 && field[0] == '+' && field[1] != '-' && field[1] != '+') field.remove_prefix(1);
  parsed_number parsed;
  const char* const end = field.data() + field.size();
  const auto [stop, ec] = std::from_chars(field.data(), end, parsed.value);
  if (ec == std::errc::result_out_of_range && stop == end) {
    parsed.error = number_error::out_of_range;
  } else if (ec != std::errc{} || stop != end) {
    parsed.error = number_error::not_a_number;
  } else if (!std::isfinite(parsed.value)) {
    parsed.error = number_error::not_finite;
  }
  return parsed;
}

atom_record_fields split_atom_record(std::string_view fields) {
  atom_record_fields out;
  std::string_view field;
  while (out.number_count < record_number_count) {
    if (field.empty()) {
      field = pop_last_field(fields);
      if (field.empty()) break;
    }
    out.numbers[record_number_count - 1 - out.number_count] = pop_last_piece(field);
    ++out.number_count;
  }
  if (!field.empty()) {  // the front of a fused field, e.g. a residue number touching x: a field of its own
    out.residue_field = field;
    ++out.leading_count;
  }
  for (std::string_view leading = pop_last_field(fields); !leading.empty(); leading = pop_last_field(fields)) {
    if (out.residue_field.empty()) out.residue_field = leading;
    ++out.leading_count;
  }
  return out;
}

std::size_t find_invalid_utf8(std::string_view bytes) {
  std::size_t i = 0;
  while (i < bytes.size()) {
    if (static_cast<unsigned char>(bytes[i]) < 0x80) {
      ++i;
      continue;
    }
    const std::size_t length = utf8_sequence_length(bytes, i);
    if (length == 0) return i;
    i += length;
  }
  return std::string_view::npos;
}

}  // namespace tracemesh::detail
