// Fuzz target for the response-side header parsers: Accept-Encoding negotiation (server/http/content_coding.hpp) and
// Range / If-Range decisions (server/http/byte_range.hpp). Input: the first line is the Range field, the second the
// If-Range field, the rest the Accept-Encoding field; the representation length is the input's size times 7.
// Checks, beyond "no crash": a partial range lies inside the representation and is not empty; Content-Range names
// it; negotiation of an incompressible response never picks gzip or br; a field that names no coding at all (no
// letters) leaves identity acceptable.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include "server/http/byte_range.hpp"
#include "server/http/content_coding.hpp"

namespace {

void check(bool condition) {
  if (!condition) std::abort();
}

std::string_view next_line(std::string_view& text) {
  const std::size_t end = text.find('\n');
  const std::string_view line = text.substr(0, end);
  text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
  return line;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::uint64_t length = static_cast<std::uint64_t>(size) * 7;
  const std::string_view range = next_line(text);
  const std::string_view if_range = next_line(text);
  const std::string etag = "\"abc-off\"";

  for (const bool with_if_range : {false, true}) {
    const tracemesh::server::range_decision decision =
        tracemesh::server::decide_range(range, with_if_range ? std::optional(if_range) : std::nullopt, etag, length);
    using tracemesh::server::range_outcome;
    if (decision.outcome == range_outcome::partial) {
      check(decision.range.length > 0);
      check(decision.range.first < length && decision.range.length <= length - decision.range.first);
      const std::string value = tracemesh::server::content_range(decision, length);
      check(value == "bytes " + std::to_string(decision.range.first) + "-" +
                         std::to_string(decision.range.first + decision.range.length - 1) + "/" +
                         std::to_string(length));
    }
  }

  using tracemesh::server::content_coding;
  const auto incompressible = tracemesh::server::negotiate_coding(text, false);
  check(!incompressible || *incompressible == content_coding::identity);
  const auto compressible = tracemesh::server::negotiate_coding(text, true);
  if (text.find_first_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ*") == std::string_view::npos) {
    check(compressible == content_coding::identity);
  }
  return 0;
}
