#pragma once
/// @file text_lines.hpp
/// Private helper of the text readers (PQR, xyzr, PDB): splits text into lines and rejects what is not text,
/// with the same rules and messages for every format. Not part of the public API.
///
/// - One UTF-8 byte order mark at the very start is skipped; a UTF-16 byte order mark is an error.
/// - Lines end with LF, CRLF or a bare CR; the last line may have no terminator.
/// - A control byte other than tab (NUL, 0x01–0x08, 0x0B, 0x0C, 0x0E–0x1F, 0x7F) or bytes that are not UTF-8
///   are errors: the input is binary. A line longer than max_line_bytes is an error, found without scanning
///   more than max_line_bytes + 1 bytes of it.

#include <cstddef>
#include <string>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh::detail {

/// `text` without its leading and trailing blanks (spaces and tabs).
std::string_view trimmed(std::string_view text);

/// Whether `line` starts with the upper-case record name `prefix` in any case ("ATOM", "atom", "REMA"): gemmi's
/// test of a PDB record, which the PDB readers and checks use alike.
bool has_record_prefix(std::string_view line, std::string_view prefix);

/// errc::invalid_input "line N: what".
status line_error(std::size_t line_number, const std::string& what);

class text_lines {
 public:
  /// `format` names the expected text in messages ("PQR" → "binary data, not PQR text").
  text_lines(std::string_view text, std::size_t max_line_bytes, std::string_view format);

  /// The next line (terminator excluded) in `line`; false once the text is exhausted. Errors as above, each a
  /// line_error naming the line.
  result<bool> next(std::string_view& line);

  /// 1-based number of the line last returned (0 before the first).
  std::size_t line_number() const { return line_number_; }

  /// Bytes of text after the byte order mark (for sizing allocations).
  std::size_t size() const { return text_.size(); }

 private:
  status find_line_end(std::size_t begin, std::size_t& end) const;
  status check_utf8(std::string_view line) const;

  std::string_view text_;
  std::size_t max_line_bytes_;
  std::string format_;
  std::size_t begin_ = 0;
  std::size_t line_number_ = 0;
  bool utf16_ = false;
};

}  // namespace tracemesh::detail
