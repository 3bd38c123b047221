// Fuzz target for server/http/multipart_parser.hpp (service-test-list item 52).
// Input: the first byte picks a chunk size (1..256), the rest is a multipart body for the fixed boundary below.
// The body is parsed whole and in chunks; both parses must agree on the status and on every part, and no
// limit may be exceeded by what the parser stores.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "server/http/multipart_parser.hpp"

namespace {

constexpr std::string_view fuzz_boundary = "fuzzboundary";

struct outcome {
  tracemesh::status result;
  std::vector<tracemesh::server::multipart_part> parts;
};

// Small limits so that the fuzzer reaches every limit path with short inputs.
tracemesh::server::multipart_limits fuzz_limits() {
  tracemesh::server::multipart_limits limits;
  limits.max_parts = 8;
  limits.max_part_header_bytes = 256;
  limits.max_field_bytes = 64;
  limits.max_file_bytes = 4096;
  return limits;
}

outcome parse(std::string_view body, std::size_t chunk_size) {
  tracemesh::server::multipart_parser parser{std::string(fuzz_boundary), fuzz_limits()};
  tracemesh::status fed;
  for (std::size_t pos = 0; pos < body.size() && fed.ok(); pos += chunk_size) {
    fed = parser.feed(body.substr(pos, chunk_size));
  }
  tracemesh::status finished = parser.finish();
  return {fed.ok() ? finished : fed, std::move(parser.parts())};
}

void require(bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "multipart_parser_fuzzer: %s\n", what);
    std::abort();
  }
}

bool same_part(const tracemesh::server::multipart_part& a, const tracemesh::server::multipart_part& b) {
  return a.name == b.name && a.filename == b.filename && a.content_type == b.content_type && a.body == b.body;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::size_t chunk_size = std::size_t{data[0]} + 1;
  const std::string_view body(reinterpret_cast<const char*>(data + 1), size - 1);

  const outcome whole = parse(body, body.size() + 1);
  const outcome chunked = parse(body, chunk_size);
  require(whole.result.code() == chunked.result.code(), "status code depends on chunking");
  require(whole.result.message() == chunked.result.message(), "error message depends on chunking");
  require(whole.parts.size() == chunked.parts.size(), "part count depends on chunking");
  const auto limits = fuzz_limits();
  require(whole.parts.size() <= limits.max_parts, "more parts than max_parts");
  for (std::size_t i = 0; i < whole.parts.size(); ++i) {
    require(same_part(whole.parts[i], chunked.parts[i]), "part contents depend on chunking");
    const std::size_t limit = whole.parts[i].filename ? limits.max_file_bytes : limits.max_field_bytes;
    require(whole.parts[i].body.size() <= limit, "part body over its limit");
  }
  return 0;
}
