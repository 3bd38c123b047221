#include "server/http/multipart_parser.hpp"

#include <algorithm>
#include <cstring>
#include <utility>

#include "server/http/detail/http_text.hpp"

namespace tracemesh::server {
namespace {

using detail::iequals;
using detail::trim;

bool is_space_or_tab(char c) { return c == ' ' || c == '\t'; }

// RFC 7230 tchar: the characters of a token (header names, parameter names, unquoted values).
bool is_token_char(char c) {
  if ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z')) return true;
  return std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

// RFC 2046 bcharsnospace.
bool is_boundary_char_no_space(char c) {
  if ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z')) return true;
  return std::string_view("'()+_,-./:=?").find(c) != std::string_view::npos;
}

// Control characters other than tab may not appear in header values.
bool is_forbidden_header_char(char c) {
  const auto byte = static_cast<unsigned char>(c);
  return (byte < 0x20 && c != '\t') || byte == 0x7f;
}

/// A `; name=value` parameter list, as in Content-Type and Content-Disposition header values.
/// Values are tokens or quoted strings; in a quoted string a backslash escapes only '"' and '\' (browsers send
/// Windows paths with raw backslashes, RFC 7578 §4.2).
class parameter_reader {
 public:
  explicit parameter_reader(std::string_view text) : text_(text) {}

  /// Reads the next parameter. Returns false at the end of the list or on a syntax error (then error() is true).
  bool next(std::string_view& name, std::string& value) {
    skip_whitespace();
    if (pos_ == text_.size()) return false;
    if (text_[pos_] != ';') return fail();
    ++pos_;
    skip_whitespace();
    if (pos_ == text_.size()) return false;  // a trailing ';' is tolerated
    const std::size_t name_start = pos_;
    while (pos_ < text_.size() && is_token_char(text_[pos_])) ++pos_;
    name = text_.substr(name_start, pos_ - name_start);
    skip_whitespace();
    if (name.empty() || pos_ == text_.size() || text_[pos_] != '=') return fail();
    ++pos_;
    skip_whitespace();
    return pos_ < text_.size() && text_[pos_] == '"' ? read_quoted(value) : read_token(value);
  }

  bool error() const { return error_; }

 private:
  void skip_whitespace() {
    while (pos_ < text_.size() && is_space_or_tab(text_[pos_])) ++pos_;
  }

  bool fail() {
    error_ = true;
    return false;
  }

  bool read_quoted(std::string& value) {
    value.clear();
    for (++pos_; pos_ < text_.size(); ++pos_) {
      const char c = text_[pos_];
      if (c == '"') {
        ++pos_;
        return true;
      }
      const bool escape = c == '\\' && pos_ + 1 < text_.size() && (text_[pos_ + 1] == '"' || text_[pos_ + 1] == '\\');
      if (escape) ++pos_;
      value.push_back(text_[pos_]);
    }
    return fail();  // unterminated quoted string
  }

  bool read_token(std::string& value) {
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != ';' && !is_space_or_tab(text_[pos_])) ++pos_;
    value.assign(text_.substr(start, pos_ - start));
    return !value.empty() || fail();
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  bool error_ = false;
};

/// Splits a header value at its first ';' into the leading value and the parameter list.
std::pair<std::string_view, std::string_view> split_parameters(std::string_view value) {
  const auto semicolon = value.find(';');
  if (semicolon == std::string_view::npos) return {trim(value), {}};
  return {trim(value.substr(0, semicolon)), value.substr(semicolon)};
}

}  // namespace

bool is_multipart_form_data(std::string_view content_type) {
  return iequals(split_parameters(content_type).first, "multipart/form-data");
}

bool is_valid_boundary(std::string_view boundary) {
  if (boundary.empty() || boundary.size() > max_boundary_length || boundary.back() == ' ') return false;
  for (const char c : boundary) {
    if (c != ' ' && !is_boundary_char_no_space(c)) return false;
  }
  return true;
}

result<std::string> multipart_boundary(std::string_view content_type) {
  if (!is_multipart_form_data(content_type)) {
    return status(errc::invalid_input, "Content-Type is not multipart/form-data");
  }
  parameter_reader reader(split_parameters(content_type).second);
  std::optional<std::string> boundary;
  std::string_view name;
  std::string value;
  while (reader.next(name, value)) {
    if (!iequals(name, "boundary")) continue;
    if (boundary) return status(errc::invalid_input, "Content-Type has more than one boundary parameter");
    boundary = value;
  }
  if (reader.error()) return status(errc::invalid_input, "malformed Content-Type parameters");
  if (!boundary) return status(errc::invalid_input, "multipart/form-data Content-Type without a boundary");
  if (!is_valid_boundary(*boundary)) {
    return status(errc::invalid_input,
                  "invalid multipart boundary (1-70 characters of RFC 2046 bchars, not ending with a space)");
  }
  return std::move(*boundary);
}

multipart_parser::multipart_parser(std::string boundary, multipart_limits limits)
    : delimiter_("\r\n--" + boundary), limits_(limits) {
  if (!is_valid_boundary(boundary)) {
    fail(errc::invalid_input, "invalid multipart boundary");
    return;
  }
  // The body may open with "--boundary" directly: pretend a CRLF precedes it, so the first delimiter has the
  // same shape as every other one.
  matched_ = 2;
}

status multipart_parser::feed(std::string_view chunk) {
  std::size_t pos = 0;
  while (error_.ok() && pos < chunk.size()) {
    switch (state_) {
      case state::preamble:
      case state::body:
        pos += scan_for_delimiter(chunk.substr(pos));
        break;
      case state::epilogue:
        pos = chunk.size();
        break;
      case state::header_line:
      case state::header_lf:
        consume_header_byte(chunk[pos++]);
        if (state_ == state::body) reserve_file_body(consumed_bytes_ + pos);
        break;
      case state::after_boundary:
      case state::after_close_dash:
      case state::boundary_padding:
      case state::boundary_lf:
        consume_delimiter_byte(chunk[pos++]);
        break;
    }
  }
  consumed_bytes_ += chunk.size();
  return error_;
}

status multipart_parser::finish() {
  if (!error_.ok()) return error_;
  switch (state_) {
    case state::epilogue:
      return error_;
    case state::preamble:
      fail(errc::invalid_input, "no multipart boundary found in the body");
      break;
    case state::header_line:
    case state::header_lf:
      fail(errc::invalid_input, "multipart body ended inside the headers of " + part_label());
      break;
    case state::body:
      fail(errc::invalid_input, "missing final multipart boundary (body ended inside " + part_label() + ")");
      break;
    case state::after_boundary:
    case state::after_close_dash:
    case state::boundary_padding:
    case state::boundary_lf:
      fail(errc::invalid_input, "missing final multipart boundary (body ended after a boundary line)");
      break;
  }
  return error_;
}

// Consumes bytes of `data` in the preamble or a part body until a full delimiter has been read (then the state
// changes and the rest of the chunk is left to feed()). Returns the number of bytes consumed.
std::size_t multipart_parser::scan_for_delimiter(std::string_view data) {
  std::size_t i = 0;
  while (i < data.size() && error_.ok()) {
    if (matched_ == 0) {
      // Fast path: everything up to the next CR is data.
      const void* cr = std::memchr(data.data() + i, '\r', data.size() - i);
      const std::size_t cr_index = cr ? static_cast<std::size_t>(static_cast<const char*>(cr) - data.data())
                                      : data.size();
      append_to_body(data.substr(i, cr_index - i));
      i = cr_index;
      if (i == data.size()) break;
      matched_ = 1;
      ++i;
    } else if (data[i] == delimiter_[matched_]) {
      ++i;
      if (++matched_ == delimiter_.size()) {
        matched_ = 0;
        on_delimiter();
        break;
      }
    } else {
      // The held-back bytes were data after all; re-examine data[i] from a fresh start.
      append_to_body(std::string_view(delimiter_).substr(0, matched_));
      matched_ = 0;
    }
  }
  return i;
}

void multipart_parser::on_delimiter() {
  if (state_ == state::body) {
    parts_.push_back(std::move(current_));
    current_ = {};
  }
  state_ = state::after_boundary;
  header_bytes_ = 0;
}

void multipart_parser::consume_delimiter_byte(char c) {
  count_header_byte();
  if (!error_.ok()) return;
  switch (state_) {
    case state::after_boundary:
      if (c == '-') {
        state_ = state::after_close_dash;
        return;
      }
      [[fallthrough]];
    case state::boundary_padding:
      if (is_space_or_tab(c)) {
        state_ = state::boundary_padding;
      } else if (c == '\r') {
        state_ = state::boundary_lf;
      } else {
        fail(errc::invalid_input, "unexpected bytes after a multipart boundary (boundary inside a part?)");
      }
      return;
    case state::after_close_dash:
      if (c == '-') {
        state_ = state::epilogue;
      } else {
        fail(errc::invalid_input, "malformed final multipart boundary (expected \"--\")");
      }
      return;
    case state::boundary_lf:
      if (c == '\n') {
        start_part();
      } else {
        fail(errc::invalid_input, "bare CR after a multipart boundary");
      }
      return;
    default:
      return;
  }
}

void multipart_parser::start_part() {
  if (parts_.size() >= limits_.max_parts) {
    fail(errc::limit_exceeded, "more than " + std::to_string(limits_.max_parts) + " multipart parts");
    return;
  }
  current_ = {};
  current_is_file_ = false;
  seen_disposition_ = false;
  seen_content_type_ = false;
  header_line_.clear();
  pending_header_.clear();
  state_ = state::header_line;
}

void multipart_parser::count_header_byte() {
  if (++header_bytes_ > limits_.max_part_header_bytes) {
    fail(errc::limit_exceeded,
         "multipart part headers exceed " + std::to_string(limits_.max_part_header_bytes) + " bytes");
  }
}

void multipart_parser::consume_header_byte(char c) {
  count_header_byte();
  if (!error_.ok()) return;
  if (state_ == state::header_lf) {
    if (c == '\n') {
      end_of_header_line();
    } else {
      fail(errc::invalid_input, "bare CR in multipart part headers");
    }
  } else if (c == '\r') {
    state_ = state::header_lf;
  } else if (c == '\n') {
    fail(errc::invalid_input, "bare LF in multipart part headers (lines must end with CRLF)");
  } else {
    header_line_.push_back(c);
  }
}

// A header line is parsed only once the next line has started, so that a folded continuation (obs-fold) is
// reported as such instead of as whatever the truncated first line lacks.
void multipart_parser::end_of_header_line() {
  state_ = state::header_line;
  if (!header_line_.empty() && is_space_or_tab(header_line_.front())) {
    fail(errc::invalid_input, "folded multipart part header lines are not supported");
    return;
  }
  if (!pending_header_.empty()) parse_header(pending_header_);
  pending_header_.swap(header_line_);
  header_line_.clear();
  if (pending_header_.empty() && error_.ok()) end_of_headers();
}

void multipart_parser::end_of_headers() {
  if (!seen_disposition_) {
    fail(errc::invalid_input, "multipart part without a Content-Disposition header (empty part headers?)");
    return;
  }
  if (!seen_content_type_) current_.content_type = "text/plain";
  state_ = state::body;
}

// Reserves a file part's memory from the size hint: the part starts at `body_offset` of the body, so the rest
// of the body bounds its size.
void multipart_parser::reserve_file_body(std::size_t body_offset) {
  if (!current_is_file_ || body_size_hint_ <= body_offset) return;
  current_.body.reserve(std::min(body_size_hint_ - body_offset, limits_.max_file_bytes));
}

void multipart_parser::parse_header(std::string_view line) {
  const auto colon = line.find(':');
  if (colon == std::string_view::npos) {
    fail(errc::invalid_input, "multipart part header line without a colon");
    return;
  }
  const std::string_view name = line.substr(0, colon);
  for (const char c : name) {
    if (!is_token_char(c)) {
      fail(errc::invalid_input, "invalid multipart part header name");
      return;
    }
  }
  if (name.empty()) {
    fail(errc::invalid_input, "empty multipart part header name");
    return;
  }
  const std::string_view value = trim(line.substr(colon + 1));
  for (const char c : value) {
    if (is_forbidden_header_char(c)) {
      fail(errc::invalid_input, "control character in a multipart part header value");
      return;
    }
  }
  if (iequals(name, "content-disposition")) {
    if (seen_disposition_) {
      fail(errc::invalid_input, "multipart part with two Content-Disposition headers");
      return;
    }
    seen_disposition_ = true;
    parse_content_disposition(value);
  } else if (iequals(name, "content-type")) {
    if (seen_content_type_) {
      fail(errc::invalid_input, "multipart part with two Content-Type headers");
      return;
    }
    seen_content_type_ = true;
    current_.content_type.assign(value);
  }
}

void multipart_parser::parse_content_disposition(std::string_view value) {
  const auto [disposition, parameters] = split_parameters(value);
  if (!iequals(disposition, "form-data")) {
    fail(errc::invalid_input, "multipart part is not Content-Disposition: form-data");
    return;
  }
  parameter_reader reader(parameters);
  std::optional<std::string> name;
  std::string_view parameter;
  std::string parameter_value;
  while (reader.next(parameter, parameter_value)) {
    if (iequals(parameter, "name") || iequals(parameter, "filename")) {
      auto& slot = iequals(parameter, "name") ? name : current_.filename;
      if (slot) {
        fail(errc::invalid_input, "Content-Disposition repeats a parameter");
        return;
      }
      slot = parameter_value;
    }
  }
  if (reader.error()) {
    fail(errc::invalid_input, "malformed Content-Disposition parameters");
    return;
  }
  if (!name) {
    fail(errc::invalid_input, "Content-Disposition without a name parameter");
    return;
  }
  current_.name = std::move(*name);
  current_is_file_ = current_.filename.has_value();
}

void multipart_parser::append_to_body(std::string_view bytes) {
  if (state_ != state::body || bytes.empty()) return;  // preamble bytes are discarded
  const std::size_t limit = current_is_file_ ? limits_.max_file_bytes : limits_.max_field_bytes;
  if (bytes.size() > limit - current_.body.size()) {
    fail(errc::limit_exceeded, part_label() + " exceeds " + std::to_string(limit) + " bytes (" +
                                   (current_is_file_ ? "max_file_bytes" : "max_field_bytes") + ")");
    return;
  }
  current_.body.append(bytes);
}

void multipart_parser::fail(errc code, std::string message) {
  if (error_.ok()) error_ = status(code, std::move(message));
}

// "part 3 ('pqr')": names are echoed only when they are short plain tokens, never arbitrary client bytes.
std::string multipart_parser::part_label() const {
  std::string label = "multipart part " + std::to_string(parts_.size() + 1);
  const std::string& name = current_.name;
  bool plain = !name.empty() && name.size() <= 64;
  for (const char c : name) plain = plain && (is_token_char(c) && c != '\'');
  if (plain) label += " ('" + name + "')";
  return label;
}

}  // namespace tracemesh::server
