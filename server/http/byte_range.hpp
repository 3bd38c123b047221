#pragma once
/// @file byte_range.hpp
/// Range requests on a representation of known length (RFC 9110 §14): the Range field of a GET, checked against
/// If-Range, becomes one of
///   - full:          no Range, a Range that does not parse or names another unit, an If-Range that does not
///                    match, or several ranges (answered whole with 200: multipart/byteranges is not produced);
///   - partial:       one satisfiable range "bytes=a-b", "bytes=a-" or "bytes=-n" (suffix), clipped to the length
///                    → 206 with Content-Range: bytes a-b/len;
///   - unsatisfiable: one range starting at or past the end, or "-0" → 416 with Content-Range: bytes */len.
/// If-Range must be a strong entity tag equal to the representation's (a weak tag or an HTTP date never matches:
/// the service sends no Last-Modified), else the whole representation is sent.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tracemesh::server {

struct byte_range {
  std::uint64_t first = 0;
  std::uint64_t length = 0;
};

enum class range_outcome { full, partial, unsatisfiable };

struct range_decision {
  range_outcome outcome = range_outcome::full;
  byte_range range;  ///< partial only
};

/// The decision for a GET of a representation of `size` bytes whose ETag is `etag`. `range` and `if_range`:
/// the request's fields, nullopt when absent.
range_decision decide_range(std::optional<std::string_view> range, std::optional<std::string_view> if_range,
                            std::string_view etag, std::uint64_t size);

/// "bytes a-b/size" (partial) or "bytes */size" (unsatisfiable): the Content-Range value.
std::string content_range(const range_decision& decision, std::uint64_t size);

}  // namespace tracemesh::server
