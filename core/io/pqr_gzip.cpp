#include "core/io/pqr_gzip.hpp"

#define ZLIB_CONST  // z_stream::next_in becomes a pointer to const: no cast of the caller's bytes
#include <zlib.h>

#include <algorithm>
#include <climits>
#include <limits>

#include "core/io/pqr_text.hpp"

namespace tracemesh::detail {

namespace {

/// First output buffer size when nothing better is known; the buffer then doubles as needed.
constexpr std::size_t initial_output_bytes = 64 * 1024;
/// Typical PQR compression ratio, used to size the first output buffer (fewer regrowths).
constexpr std::size_t expected_compression_ratio = 4;
/// The first output buffer never exceeds this multiple of the input, whatever the gzip trailer claims.
constexpr std::size_t max_trusted_compression_ratio = 16;
/// Smallest gzip member: 10-byte header, empty deflate block, 8-byte trailer.
constexpr std::size_t min_gzip_member_bytes = 18;
/// zlib counts bytes in uInt: feed and drain at most this much per call.
constexpr std::size_t max_zlib_chunk = std::numeric_limits<uInt>::max();

status corrupt(std::string_view what) { return {errc::invalid_input, "corrupt gzip stream: " + std::string(what)}; }

/// Owns a zlib inflate state set up for gzip-wrapped input.
class gzip_inflater {
 public:
  gzip_inflater() { ready_ = inflateInit2(&stream_, 16 + MAX_WBITS) == Z_OK; }
  ~gzip_inflater() {
    if (ready_) inflateEnd(&stream_);
  }
  gzip_inflater(const gzip_inflater&) = delete;
  gzip_inflater& operator=(const gzip_inflater&) = delete;

  bool ready() const { return ready_; }
  z_stream& stream() { return stream_; }

 private:
  z_stream stream_{};
  bool ready_ = false;
};

/// Output buffer that grows geometrically but never beyond max_bytes + 1: one byte past the limit is how an
/// oversized stream is detected without inflating the rest of it.
class bounded_output {
 public:
  bounded_output(std::size_t max_bytes, std::size_t size_hint)
      : max_bytes_(max_bytes),
        capacity_limit_(max_bytes == std::numeric_limits<std::size_t>::max() ? max_bytes : max_bytes + 1) {
    bytes_.resize(std::min(capacity_limit_, std::max(size_hint, initial_output_bytes)));
  }

  bool over_limit() const { return produced_ > max_bytes_; }

  /// Points `stream` at the free part of the buffer, growing it first when full.
  void provide_space(z_stream& stream) {
    if (produced_ == bytes_.size()) {
      const std::size_t doubled = bytes_.size() > capacity_limit_ / 2 ? capacity_limit_ : bytes_.size() * 2;
      bytes_.resize(doubled);
    }
    stream.next_out = reinterpret_cast<Bytef*>(bytes_.data() + produced_);
    stream.avail_out = static_cast<uInt>(std::min(bytes_.size() - produced_, max_zlib_chunk));
  }
  void record_written(std::size_t count) { produced_ += count; }

  std::string release() && {
    bytes_.resize(produced_);
    return std::move(bytes_);
  }

 private:
  std::size_t max_bytes_;
  std::size_t capacity_limit_;
  std::size_t produced_ = 0;
  std::string bytes_;
};

/// First output buffer size: the last member's ISIZE trailer (its size mod 2^32; exact for a usual single-member
/// file, so no regrowth), else a typical ratio. Capped so that a forged trailer cannot make a tiny input reserve
/// a large buffer.
std::size_t output_size_hint(std::string_view compressed, std::size_t max_bytes) {
  const std::size_t trusted = compressed.size() > max_bytes / max_trusted_compression_ratio
                                  ? max_bytes
                                  : compressed.size() * max_trusted_compression_ratio;
  if (compressed.size() < min_gzip_member_bytes) return std::min(trusted, initial_output_bytes);
  const auto* trailer = reinterpret_cast<const unsigned char*>(compressed.data() + compressed.size() - 4);
  const std::size_t isize = std::size_t{trailer[0]} | std::size_t{trailer[1]} << 8 | std::size_t{trailer[2]} << 16 |
                            std::size_t{trailer[3]} << 24;
  const std::size_t typical = compressed.size() * expected_compression_ratio;
  return std::min(trusted, std::max(isize + 1, typical));  // + 1: room to read the trailer without regrowing
}

}  // namespace

bool has_gzip_magic(std::string_view bytes) noexcept {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
         static_cast<unsigned char>(bytes[1]) == 0x8b;
}

result<std::string> gunzip(std::string_view compressed, std::size_t max_bytes) {
  gzip_inflater inflater;
  if (!inflater.ready()) return status{errc::internal_error, "gzip: zlib could not initialise"};
  z_stream& stream = inflater.stream();
  bounded_output output(max_bytes, output_size_hint(compressed, max_bytes));
  const auto* const input = reinterpret_cast<const Bytef*>(compressed.data());
  std::size_t handed_to_zlib = 0;  // input bytes given to zlib so far (some may still be in avail_in)

  for (;;) {
    if (stream.avail_in == 0 && handed_to_zlib < compressed.size()) {
      const std::size_t chunk = std::min(compressed.size() - handed_to_zlib, max_zlib_chunk);
      stream.next_in = input + handed_to_zlib;
      stream.avail_in = static_cast<uInt>(chunk);
      handed_to_zlib += chunk;
    }
    output.provide_space(stream);
    const uInt space_before = stream.avail_out;
    const int code = inflate(&stream, Z_NO_FLUSH);
    output.record_written(space_before - stream.avail_out);
    if (output.over_limit()) {
      return status{errc::limit_exceeded,
                    "gzip: decompressed data is larger than " + std::to_string(max_bytes) + " bytes"};
    }
    const std::size_t unread = compressed.size() - handed_to_zlib + stream.avail_in;
    switch (code) {
      case Z_OK:
        break;
      case Z_STREAM_END:
        if (unread == 0) return std::move(output).release();
        if (!has_gzip_magic(compressed.substr(compressed.size() - unread))) {
          return corrupt(std::to_string(unread) + " bytes after the end of the last gzip member");
        }
        inflateReset(&stream);  // another member follows (concatenated .gz files)
        break;
      case Z_BUF_ERROR:  // no progress possible: either out of input (truncated) or out of output space
        if (unread == 0) return corrupt("truncated (input ends inside a gzip member)");
        break;
      case Z_MEM_ERROR:
        return status{errc::internal_error, "gzip: zlib is out of memory"};
      default:  // Z_DATA_ERROR, Z_NEED_DICT, Z_STREAM_ERROR
        return corrupt(quote_bytes(stream.msg != nullptr ? stream.msg : "invalid data"));
    }
  }
}

}  // namespace tracemesh::detail
