// Accept-Encoding negotiation (RFC 9110 §12.5.3) and the gzip/br compressors, round-tripped through zlib's and
// libbrotli's decoders.
#include "server/http/content_coding.hpp"

#include <gtest/gtest.h>

#include <brotli/decode.h>
#include <zlib.h>

#include <optional>
#include <string>

namespace tracemesh::server {
namespace {

std::optional<content_coding> pick(const char* accept, bool compressible = true) {
  return negotiate_coding(std::optional<std::string_view>(accept), compressible);
}

TEST(NegotiateCoding, NoFieldOrEmptyFieldIsIdentity) {
  EXPECT_EQ(negotiate_coding(std::nullopt, true), content_coding::identity);
  EXPECT_EQ(pick(""), content_coding::identity);
  EXPECT_EQ(pick("  "), content_coding::identity);
}

TEST(NegotiateCoding, HighestWeightWinsAndTiesGoToBrThenGzip) {
  EXPECT_EQ(pick("gzip"), content_coding::gzip);
  EXPECT_EQ(pick("br"), content_coding::br);
  EXPECT_EQ(pick("gzip, deflate, br"), content_coding::br);
  EXPECT_EQ(pick("gzip;q=1.0, br;q=0.9"), content_coding::gzip);
  EXPECT_EQ(pick("br;q=0.5, gzip;q=0.5"), content_coding::br);
  EXPECT_EQ(pick("GZIP"), content_coding::gzip);
  EXPECT_EQ(pick("x-gzip"), content_coding::gzip);
  EXPECT_EQ(pick("deflate"), content_coding::identity);  // identity stays acceptable when not refused
  EXPECT_EQ(pick("gzip;q=0.2, identity;q=0.5"), content_coding::identity);
  EXPECT_EQ(pick("identity"), content_coding::identity);
  // An unnamed identity has the lowest weight: any coding the client names wins.
  EXPECT_EQ(pick("gzip;q=0.01"), content_coding::gzip);
}

TEST(NegotiateCoding, StarCoversEveryCodingNotNamed) {
  EXPECT_EQ(pick("*"), content_coding::br);
  EXPECT_EQ(pick("*;q=0.5, gzip"), content_coding::gzip);
  EXPECT_EQ(pick("br;q=0, *"), content_coding::gzip);
  EXPECT_EQ(pick("*;q=0, gzip"), content_coding::gzip);
}

TEST(NegotiateCoding, RefusalsAreHonouredAndNothingAcceptableIsNullopt) {
  EXPECT_EQ(pick("gzip;q=0"), content_coding::identity);
  EXPECT_EQ(pick("gzip;q=0, br;q=0"), content_coding::identity);
  EXPECT_EQ(pick("identity;q=0"), std::nullopt);
  EXPECT_EQ(pick("*;q=0"), std::nullopt);
  EXPECT_EQ(pick("identity;q=0, gzip"), content_coding::gzip);
  EXPECT_EQ(pick("*;q=0, br;q=0.3"), content_coding::br);
  EXPECT_EQ(pick("*;q=0, identity"), content_coding::identity);
}

TEST(NegotiateCoding, IncompressibleResponsesOnlyHaveIdentity) {
  EXPECT_EQ(pick("br, gzip", false), content_coding::identity);
  EXPECT_EQ(pick("identity;q=0, br", false), std::nullopt);
  EXPECT_EQ(pick("*;q=0", false), std::nullopt);
}

TEST(NegotiateCoding, MalformedWeightsIgnoreTheirElement) {
  EXPECT_EQ(pick("br;q=2, gzip"), content_coding::gzip);
  EXPECT_EQ(pick("br;q=0.12345, gzip"), content_coding::gzip);
  EXPECT_EQ(pick("br;q=, gzip"), content_coding::gzip);
  EXPECT_EQ(pick("identity;q=x"), content_coding::identity);  // the refusal did not parse: not a refusal
  EXPECT_EQ(pick(",,;,br ; q=0.7 ;foo=bar,"), content_coding::br);
  EXPECT_EQ(pick("gzip;Q=0"), content_coding::identity);
}

std::string gunzip(const std::string& bytes) {
  z_stream stream{};
  EXPECT_EQ(inflateInit2(&stream, 15 + 16), Z_OK);
  std::string out(bytes.size() * 20 + 1024, '\0');
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  stream.avail_in = static_cast<uInt>(bytes.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(inflate(&stream, Z_FINISH), Z_STREAM_END);
  out.resize(stream.total_out);
  inflateEnd(&stream);
  return out;
}

std::string unbrotli(const std::string& bytes) {
  std::string out(bytes.size() * 20 + 1024, '\0');
  std::size_t size = out.size();
  EXPECT_EQ(BrotliDecoderDecompress(bytes.size(), reinterpret_cast<const std::uint8_t*>(bytes.data()), &size,
                                    reinterpret_cast<std::uint8_t*>(out.data())),
            BROTLI_DECODER_RESULT_SUCCESS);
  out.resize(size);
  return out;
}

std::string off_like_text() {
  std::string text = "OFF\n2000 1000 0\n";
  for (int i = 0; i < 2000; ++i) {
    text += std::to_string(i * 0.125) + " " + std::to_string(-i * 0.5) + " " + std::to_string(i % 17) + "\n";
  }
  return text;
}

TEST(Compress, GzipAndBrRoundTripAndShrinkText) {
  const std::string text = off_like_text();
  const result<std::string> gz = compress(text, content_coding::gzip);
  const result<std::string> br = compress(text, content_coding::br);
  ASSERT_TRUE(gz.ok() && br.ok());
  EXPECT_EQ(static_cast<unsigned char>((*gz)[0]), 0x1f);  // a gzip member, not a zlib stream
  EXPECT_EQ(static_cast<unsigned char>((*gz)[1]), 0x8b);
  EXPECT_EQ(gunzip(*gz), text);
  EXPECT_EQ(unbrotli(*br), text);
  EXPECT_LT(gz->size(), text.size() / 2);
  EXPECT_LT(br->size(), text.size() / 2);
  EXPECT_EQ(*compress(text, content_coding::identity), text);
  EXPECT_EQ(*compress(text, content_coding::gzip), *gz);  // deterministic: the strong ETag relies on it
  EXPECT_EQ(*compress(text, content_coding::br), *br);
}

TEST(Compress, EmptyInputRoundTrips) {
  EXPECT_EQ(gunzip(*compress("", content_coding::gzip)), "");
  EXPECT_EQ(unbrotli(*compress("", content_coding::br)), "");
}

TEST(ContentCodingNames, TokensEtagTagsAndCacheSuffixesDiffer) {
  EXPECT_EQ(coding_name(content_coding::gzip), "gzip");
  EXPECT_EQ(coding_name(content_coding::br), "br");
  EXPECT_EQ(coding_name(content_coding::identity), "identity");
  EXPECT_EQ(content_coding_etag_tag(content_coding::identity), "");
  EXPECT_EQ(content_coding_etag_tag(content_coding::gzip).rfind("gz", 0), 0u);
  EXPECT_EQ(content_coding_etag_tag(content_coding::br).rfind("br", 0), 0u);
  EXPECT_EQ(coding_cache_suffix(content_coding::gzip).rfind(".gz6_z", 0), 0u);
  EXPECT_EQ(coding_cache_suffix(content_coding::br).rfind(".br4w22_b", 0), 0u);
  EXPECT_EQ(coding_cache_suffix(content_coding::gzip).find_first_of(".-", 1), std::string::npos);
  EXPECT_EQ(coding_cache_suffix(content_coding::identity), "");
}

}  // namespace
}  // namespace tracemesh::server
