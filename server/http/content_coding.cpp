#include "server/http/content_coding.hpp"

#include <algorithm>
#include <array>
#include <cstdint>

#include <brotli/encode.h>
#include <zlib.h>

#include "server/http/detail/http_text.hpp"

namespace tracemesh::server {
namespace {

using detail::iequals;
using detail::trim;

constexpr int gzip_level = 6;
constexpr int brotli_quality = 4;
constexpr int brotli_window_bits = 22;

/// Weights in thousandths (q=0.5 → 500), so comparisons are exact.
using weight = int;
constexpr weight unnamed = -1;

struct coding_weights {
  weight identity = unnamed;
  weight gzip = unnamed;
  weight br = unnamed;
  weight any = unnamed;  // "*"
};

/// RFC 9110 §12.4.2 qvalue: "0" ["." 0*3DIGIT] / "1" ["." 0*3("0")], in thousandths; nullopt when malformed.
std::optional<weight> parse_qvalue(std::string_view text) {
  if (text.empty() || (text[0] != '0' && text[0] != '1')) return std::nullopt;
  weight value = text[0] == '1' ? 1000 : 0;
  if (text.size() == 1) return value;
  if (text[1] != '.' || text.size() > 5) return std::nullopt;
  weight scale = 100;
  for (const char c : text.substr(2)) {
    if (c < '0' || c > '9') return std::nullopt;
    value += (c - '0') * scale;
    scale /= 10;
  }
  return value > 1000 ? std::nullopt : std::optional<weight>(value);
}

/// One element "coding *( OWS ; OWS param )": its name and weight (1 unless q= says otherwise); nullopt when the
/// weight does not parse.
std::optional<std::pair<std::string_view, weight>> parse_element(std::string_view element) {
  const auto semicolon = element.find(';');
  const std::string_view name = trim(element.substr(0, semicolon));
  weight q = 1000;
  std::string_view params = semicolon == std::string_view::npos ? std::string_view{} : element.substr(semicolon + 1);
  while (!params.empty()) {
    const auto next = params.find(';');
    const std::string_view param = trim(params.substr(0, next));
    params = next == std::string_view::npos ? std::string_view{} : params.substr(next + 1);
    if (param.size() >= 2 && (param[0] == 'q' || param[0] == 'Q') && param[1] == '=') {
      const std::optional<weight> parsed = parse_qvalue(param.substr(2));
      if (!parsed) return std::nullopt;
      q = *parsed;
    }
  }
  return std::pair{name, q};
}

coding_weights parse_accept_encoding(std::string_view field) {
  coding_weights weights;
  while (!field.empty()) {
    const auto comma = field.find(',');
    const std::string_view element = field.substr(0, comma);
    field = comma == std::string_view::npos ? std::string_view{} : field.substr(comma + 1);
    const auto parsed = parse_element(element);
    if (!parsed || parsed->first.empty()) continue;
    const auto [name, q] = *parsed;
    // A coding named twice keeps its highest weight.
    weight* slot = iequals(name, "identity")                           ? &weights.identity
                   : iequals(name, "gzip") || iequals(name, "x-gzip") ? &weights.gzip
                   : iequals(name, "br")                               ? &weights.br
                   : name == "*"                                       ? &weights.any
                                                                       : nullptr;
    if (slot) *slot = std::max(*slot, q);
  }
  return weights;
}

}  // namespace

std::string_view coding_name(content_coding coding) noexcept {
  switch (coding) {
    case content_coding::identity: return "identity";
    case content_coding::gzip: return "gzip";
    case content_coding::br: return "br";
  }
  return "identity";
}

std::optional<content_coding> negotiate_coding(std::optional<std::string_view> accept_encoding, bool compressible) {
  if (!accept_encoding) return content_coding::identity;
  const coding_weights weights = parse_accept_encoding(*accept_encoding);
  // identity, when neither named nor covered by "*", stays acceptable (RFC 9110 §12.5.3) as the last resort: the
  // lowest weight, so that any coding the client named wins over it.
  const weight identity = weights.identity != unnamed ? weights.identity : weights.any != unnamed ? weights.any : 1;
  const auto weight_of = [&](weight named) { return named != unnamed ? named : weights.any != unnamed ? weights.any : 0; };
  struct candidate {
    content_coding coding;
    weight q;
  };
  // In order of preference for equal weights: the smallest output first.
  std::array<candidate, 3> candidates{{{content_coding::br, compressible ? weight_of(weights.br) : 0},
                                       {content_coding::gzip, compressible ? weight_of(weights.gzip) : 0},
                                       {content_coding::identity, identity}}};
  const candidate* best = nullptr;
  for (const candidate& c : candidates) {
    if (c.q > 0 && (!best || c.q > best->q)) best = &c;
  }
  if (!best) return std::nullopt;
  return best->coding;
}

result<std::string> compress(std::string_view bytes, content_coding coding) {
  return compress_at_level(bytes, coding, coding == content_coding::br ? brotli_quality : gzip_level);
}

result<std::string> compress_at_level(std::string_view bytes, content_coding coding, int level) {
  switch (coding) {
    case content_coding::identity: return std::string(bytes);
    case content_coding::gzip: {
      z_stream stream{};
      // windowBits 15 + 16: a gzip wrapper (RFC 1952) rather than zlib's.
      if (deflateInit2(&stream, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
        return status(errc::internal_error, "gzip: deflateInit2 failed");
      }
      std::string out(deflateBound(&stream, static_cast<uLong>(bytes.size())), '\0');
      stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
      stream.avail_in = static_cast<uInt>(bytes.size());
      stream.next_out = reinterpret_cast<Bytef*>(out.data());
      stream.avail_out = static_cast<uInt>(out.size());
      const int finished = deflate(&stream, Z_FINISH);
      const std::size_t produced = stream.total_out;
      deflateEnd(&stream);
      if (finished != Z_STREAM_END) return status(errc::internal_error, "gzip: deflate did not finish");
      out.resize(produced);
      return out;
    }
    case content_coding::br: {
      std::size_t produced = BrotliEncoderMaxCompressedSize(bytes.size());
      if (produced == 0) return status(errc::internal_error, "br: input too large for one brotli call");
      std::string out(produced, '\0');
      if (!BrotliEncoderCompress(level, brotli_window_bits, BROTLI_MODE_GENERIC, bytes.size(),
                                 reinterpret_cast<const std::uint8_t*>(bytes.data()), &produced,
                                 reinterpret_cast<std::uint8_t*>(out.data()))) {
        return status(errc::internal_error, "br: BrotliEncoderCompress failed");
      }
      out.resize(produced);
      return out;
    }
  }
  return status(errc::internal_error, "unknown content coding");
}

std::string content_coding_etag_tag(content_coding coding) {
  switch (coding) {
    case content_coding::identity: return {};
    case content_coding::gzip: return "gz" + std::to_string(gzip_level) + "-z" + zlibVersion();
    case content_coding::br: {
      const std::uint32_t v = BrotliEncoderVersion();  // major << 24 | minor << 12 | patch
      return "br" + std::to_string(brotli_quality) + "w" + std::to_string(brotli_window_bits) + "-b" +
             std::to_string(v >> 24) + "." + std::to_string((v >> 12) & 0xfff) + "." + std::to_string(v & 0xfff);
    }
  }
  return {};
}

std::string coding_cache_suffix(content_coding coding) {
  std::string tag = content_coding_etag_tag(coding);
  if (tag.empty()) return tag;
  std::replace_if(tag.begin(), tag.end(), [](char c) { return c == '.' || c == '-'; }, '_');
  return "." + tag;
}

}  // namespace tracemesh::server
