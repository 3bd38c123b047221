#pragma once
/// @file content_coding.hpp
/// Response content codings (RFC 9110 §8.4, §12.5.3): which of identity, gzip and br a request's Accept-Encoding
/// lets the server send, and the compressors (zlib's gzip wrapper, Debian libbrotli's encoder).
///
/// Negotiation: codings are matched case-insensitively ("x-gzip" is gzip); each may carry a weight q (0–1, up to
/// three decimals); "*" stands for every coding not named; a coding with q=0 is refused. The acceptable coding of
/// highest weight among those the response can have wins, ties going to the smaller output (br, then gzip, then
/// identity). identity is acceptable unless refused ("identity;q=0", or "*;q=0" without identity named); when neither named nor covered by
/// "*" it has the lowest weight (any coding the client names wins over it). No
/// Accept-Encoding field at all: identity (RFC 9110 allows any coding there; uncompressed is what a client that
/// states nothing can surely read). An empty field: identity. An element that does not parse (a bad q) is
/// ignored, as if absent.
///
/// Compression levels were chosen by measurement on the OFF of 2buk_capsid (notes/helper-i.md): gzip level 6
/// (zlib's default) and brotli quality 4 with a 4 MiB window (lgwin 22). Both go into the representation's ETag
/// (content_coding_etag_tag) together with the library version, so that a strong ETag always names the same bytes
/// even when a level or a library changes.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "core/status.hpp"

namespace tracemesh::server {

enum class content_coding { identity, gzip, br };

/// JSON replies (reply::compressible) shorter than this are sent as they are: compressing a few hundred bytes saves
/// less than it costs (nginx's gzip_min_length idea; 1 KiB is about where gzip's 18-byte frame stops mattering).
inline constexpr std::size_t min_compressed_json_bytes = 1024;

/// "identity", "gzip" or "br": the Content-Encoding token.
std::string_view coding_name(content_coding coding) noexcept;

/// The coding to send for a request with `accept_encoding` (nullopt: the request has no Accept-Encoding field).
/// `compressible`: gzip and br are offered; otherwise only identity.
/// @return nullopt when nothing the response can have is acceptable (identity refused): answer 406.
std::optional<content_coding> negotiate_coding(std::optional<std::string_view> accept_encoding, bool compressible);

/// `bytes` compressed with `coding` at the levels above (identity: a copy). Deterministic: the same bytes, library
/// version and level give the same output.
/// @return errc::internal_error when the compressor fails (out of memory).
result<std::string> compress(std::string_view bytes, content_coding coding);
/// The same at another level (gzip: zlib level 1–9; br: brotli quality 0–11), for the benchmark that chose them.
result<std::string> compress_at_level(std::string_view bytes, content_coding coding, int level);

/// The short text identifying the compressed bytes' producer, for ETags: "gz6-z1.2.13" (level and zlib version),
/// "br4w22-b1.0.9" (quality, window and brotli version); empty for identity.
std::string content_coding_etag_tag(content_coding coding);

/// The cache key suffix of a compressed representation: "." + content_coding_etag_tag with '.' and '-' as '_'
/// (".gz6_z1_2_13", ".br4w22_b1_0_9"); empty for identity. Like the ETag it names level and library version, so a
/// new level or library never serves bytes cached by the old one under the new tag.
std::string coding_cache_suffix(content_coding coding);

}  // namespace tracemesh::server
