#pragma once
/// @file multipart_parser.hpp
/// Incremental multipart/form-data parser (RFC 7578 on top of RFC 2046 §5.1).
///
/// Streaming: bytes may arrive in chunks of any size, split anywhere (inside the boundary, inside a CRLF, inside a
/// header); the result is the same as for the whole body in one chunk. Time is linear in the body size and the
/// extra memory is O(1) beyond the parts it stores: the delimiter search resumes where the last chunk stopped and
/// never holds back more than a delimiter-length prefix.
///
/// Accepted syntax (decisions where the RFCs leave room):
/// - Lines end with CRLF. A bare CR or LF in a delimiter line or in part headers is an error.
/// - The preamble before the first boundary and the epilogue after the final boundary are ignored, as RFC 2046
///   §5.1.1 requires ("implementations must ignore anything that appears before the first boundary delimiter
///   line or after the last one"); data after the final boundary is therefore accepted and discarded.
/// - A boundary may be followed by transport padding (spaces, tabs) before its CRLF; any other byte after
///   "CRLF--boundary" is an error (the boundary must not occur inside a part).
/// - Every part needs `Content-Disposition: form-data; name="..."`; `filename` is optional (its presence makes
///   the part a file part). Header names are case-insensitive; folded (obs-fold) lines are rejected; headers
///   other than Content-Disposition and Content-Type are ignored. A part without Content-Type gets
///   "text/plain" (RFC 7578 §4.4).
///
/// Errors (sticky: once feed() or finish() fails, every later call returns the same status):
/// - errc::invalid_input: malformed body (distinct messages: no boundary found, missing final boundary,
///   header line without a colon, empty part headers / no Content-Disposition, bytes after a boundary...).
/// - errc::limit_exceeded: a multipart_limits bound was crossed.
/// Messages never echo body bytes (only a part's name when it is a short plain token).

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.hpp"

namespace tracemesh::server {

/// Bounds of one multipart body. The total body size is bounded by the HTTP layer (its upload limit); these
/// bound what a single part may hold.
struct multipart_limits {
  std::size_t max_parts = 16;               ///< parts in one body
  std::size_t max_part_header_bytes = 2048; ///< header block of one part, CRLFs and boundary padding included
  std::size_t max_field_bytes = 4096;       ///< body of a part without a filename (a form field)
  std::size_t max_file_bytes = 256u << 20;  ///< body of a part with a filename (an uploaded file)
};

struct multipart_part {
  std::string name;                     ///< Content-Disposition name parameter
  std::optional<std::string> filename;  ///< Content-Disposition filename parameter, when present (never trust it)
  std::string content_type;             ///< Content-Type header value, "text/plain" when absent
  std::string body;                     ///< the part's bytes, exactly as sent
};

/// Longest boundary RFC 2046 allows.
inline constexpr std::size_t max_boundary_length = 70;

/// The boundary parameter of a Content-Type header value such as
/// `multipart/form-data; boundary="----x"` (quoted or not; the media type is case-insensitive).
/// @return errc::invalid_input with the message "Content-Type is not multipart/form-data" when the media type
///         differs (→ HTTP 415), or another errc::invalid_input message when the boundary is missing, empty,
///         longer than 70 characters, ends with a space or holds characters outside RFC 2046 bchars (→ 400).
result<std::string> multipart_boundary(std::string_view content_type);

/// True iff the media type of a Content-Type value is multipart/form-data (parameters ignored); lets the
/// HTTP layer choose 415 (wrong media type) vs 400 (bad boundary) when multipart_boundary() fails.
bool is_multipart_form_data(std::string_view content_type);

/// True iff `boundary` is a valid RFC 2046 boundary (1–70 bchars, not ending with a space).
bool is_valid_boundary(std::string_view boundary);

class multipart_parser {
 public:
  /// @param boundary  as returned by multipart_boundary(); an invalid one makes every feed() fail.
  explicit multipart_parser(std::string boundary, multipart_limits limits = {});

  /// Optional: the body's total size (its Content-Length). A file part then reserves its memory once (at most
  /// max_file_bytes, address space only) instead of growing by copies: 2-3x faster on large uploads.
  void set_body_size_hint(std::size_t body_bytes) noexcept { body_size_hint_ = body_bytes; }

  /// Consume the next bytes of the body (any size, including 0). Returns the sticky error status.
  status feed(std::string_view chunk);
  /// Declare the end of the body. errc::invalid_input when the final boundary has not been seen.
  status finish();
  /// The complete parts, in body order (a part is complete once the boundary after it has been read).
  std::vector<multipart_part>& parts() { return parts_; }

  /// True once the final boundary ("--boundary--") has been read.
  bool complete() const noexcept { return state_ == state::epilogue; }
  const multipart_limits& limits() const noexcept { return limits_; }

 private:
  enum class state {
    preamble,           // before the first boundary: discarded
    after_boundary,     // just read "--boundary": expect "--", padding or CRLF
    after_close_dash,   // read "--boundary-": expect the second '-'
    boundary_padding,   // spaces/tabs after a boundary
    boundary_lf,        // read CR after a boundary line: expect LF
    header_line,        // inside a part header line
    header_lf,          // read CR in the headers: expect LF
    body,               // part body: searching for the next delimiter
    epilogue,           // after the final boundary: discarded
  };

  std::size_t scan_for_delimiter(std::string_view data);
  void consume_delimiter_byte(char c);
  void consume_header_byte(char c);
  void count_header_byte();
  void on_delimiter();
  void start_part();
  void end_of_header_line();
  void end_of_headers();
  void reserve_file_body(std::size_t body_offset);
  void parse_header(std::string_view line);
  void parse_content_disposition(std::string_view value);
  void append_to_body(std::string_view bytes);
  void fail(errc code, std::string message);
  std::string part_label() const;

  std::string delimiter_;  // "\r\n--" + boundary
  multipart_limits limits_;
  state state_ = state::preamble;
  status error_;
  // Bytes of delimiter_ matched so far (held back, not yet known to be data). The delimiter holds its only CR at
  // index 0 (boundaries cannot contain CR), so a failed partial match restarts from 0: no KMP table is needed.
  std::size_t matched_ = 0;
  std::vector<multipart_part> parts_;
  multipart_part current_;
  bool current_is_file_ = false;
  bool seen_disposition_ = false;
  bool seen_content_type_ = false;
  std::size_t body_size_hint_ = 0;
  std::size_t consumed_bytes_ = 0;  // bytes fed so far
  std::string header_line_;     // the header line being read
  std::string pending_header_;  // the previous complete line, parsed when the next one starts
  std::size_t header_bytes_ = 0;
};

}  // namespace tracemesh::server
