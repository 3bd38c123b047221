// Fuzz target of the bounded gzip decoder that request bodies (Content-Encoding: gzip) and .pqr.gz uploads go
// through (core/io/pqr_reader.hpp maybe_gunzip). Input: the first byte picks the output limit (0..8 KiB in
// 32-byte steps), the rest is the body. Invariants: plain bytes come back unchanged; a decoded body never exceeds
// the limit; the limit is exact (a body that decodes to n bytes decodes under limit n and is refused with
// limit_exceeded, not another error, under n - 1); corrupt input is invalid_input, never a crash or a hang.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/io/pqr_reader.hpp"

namespace {

void require(bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "gzip_body_fuzzer: %s\n", what);
    std::abort();
  }
}

bool starts_with_gzip_magic(std::string_view bytes) {
  return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
         static_cast<unsigned char>(bytes[1]) == 0x8b;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::size_t max_bytes = std::size_t{data[0]} * 32;
  const std::string_view body(reinterpret_cast<const char*>(data + 1), size - 1);

  const tracemesh::result<std::string> decoded = tracemesh::maybe_gunzip(body, max_bytes);
  if (!starts_with_gzip_magic(body)) {
    require(decoded.ok() && *decoded == body, "plain bytes not returned unchanged");
    return 0;
  }
  if (!decoded) {
    const auto code = decoded.error().code();
    require(code == tracemesh::errc::invalid_input || code == tracemesh::errc::limit_exceeded,
            "error other than invalid_input or limit_exceeded");
    require(!decoded.error().message().empty(), "error without a message");
    return 0;
  }
  require(decoded->size() <= max_bytes, "decoded body over the limit");
  const tracemesh::result<std::string> exact = tracemesh::maybe_gunzip(body, decoded->size());
  require(exact.ok() && *exact == *decoded, "a limit equal to the decoded size refused or changed it");
  if (!decoded->empty()) {
    const tracemesh::result<std::string> short_by_one = tracemesh::maybe_gunzip(body, decoded->size() - 1);
    require(!short_by_one && short_by_one.error().code() == tracemesh::errc::limit_exceeded,
            "a limit one byte under the decoded size not refused with limit_exceeded");
  }
  return 0;
}
