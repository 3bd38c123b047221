// Tests of server/http/multipart_parser.hpp: service-test-list section C (items 15-21) on the streaming parser.
#include "server/http/multipart_parser.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "support/test_paths.hpp"

namespace tracemesh::server {
namespace {

constexpr std::string_view boundary = "----geckoformboundary7f3a9c";

struct form_part {
  std::string name;
  std::optional<std::string> filename;
  std::string content_type;  // empty: no Content-Type header
  std::string body;
};

// What a browser or curl sends: each part as "--boundary CRLF headers CRLF CRLF body CRLF", then "--boundary--".
std::string build_body(const std::vector<form_part>& parts, std::string_view b = boundary) {
  std::string body;
  for (const form_part& part : parts) {
    body += "--" + std::string(b) + "\r\n";
    body += "Content-Disposition: form-data; name=\"" + part.name + "\"";
    if (part.filename) body += "; filename=\"" + *part.filename + "\"";
    body += "\r\n";
    if (!part.content_type.empty()) body += "Content-Type: " + part.content_type + "\r\n";
    body += "\r\n" + part.body + "\r\n";
  }
  body += "--" + std::string(b) + "--\r\n";
  return body;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct parse_outcome {
  status result;
  std::vector<multipart_part> parts;
};

parse_outcome parse_in_chunks(std::string_view body, std::size_t chunk_size, multipart_limits limits = {},
                              std::string_view b = boundary) {
  multipart_parser parser{std::string(b), limits};
  status fed;
  for (std::size_t pos = 0; pos < body.size() && fed.ok(); pos += chunk_size) {
    fed = parser.feed(body.substr(pos, chunk_size));
  }
  status finished = parser.finish();
  return {fed.ok() ? finished : fed, std::move(parser.parts())};
}

parse_outcome parse_whole(std::string_view body, multipart_limits limits = {}, std::string_view b = boundary) {
  return parse_in_chunks(body, std::max<std::size_t>(body.size(), 1), limits, b);
}

void expect_same_parts(const std::vector<multipart_part>& actual, const std::vector<form_part>& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(actual[i].name, expected[i].name) << "part " << i;
    EXPECT_EQ(actual[i].filename, expected[i].filename) << "part " << i;
    const std::string content_type = expected[i].content_type.empty() ? "text/plain" : expected[i].content_type;
    EXPECT_EQ(actual[i].content_type, content_type) << "part " << i;
    EXPECT_EQ(actual[i].body, expected[i].body) << "part " << i;
  }
}

bool same_parts(const std::vector<multipart_part>& a, const std::vector<multipart_part>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].name != b[i].name || a[i].filename != b[i].filename || a[i].content_type != b[i].content_type ||
        a[i].body != b[i].body) {
      return false;
    }
  }
  return true;
}

std::vector<form_part> realistic_form() {
  std::string pqr = read_file(testing::molecule_path("adp.pqr"));
  return {
      {"pqr", "adp.pqr", "application/octet-stream", pqr},
      {"density", std::nullopt, "", "2.0"},
      {"format", std::nullopt, "", "draco"},
  };
}

// ---- multipart_boundary / is_multipart_form_data (item 16, 20) ----------------------------------------------

TEST(MultipartBoundary, ExtractsPlainAndQuotedBoundaries) {
  EXPECT_EQ(multipart_boundary("multipart/form-data; boundary=abc123").value(), "abc123");
  EXPECT_EQ(multipart_boundary("multipart/form-data; boundary=\"abc 123\"").value(), "abc 123");
  EXPECT_EQ(multipart_boundary("Multipart/Form-Data;boundary=x").value(), "x");
  EXPECT_EQ(multipart_boundary("multipart/form-data; charset=utf-8; BOUNDARY=\"q\"").value(), "q");
  EXPECT_EQ(multipart_boundary("multipart/form-data; boundary=------geckoformboundary12ab").value(),
            "------geckoformboundary12ab");
  EXPECT_EQ(multipart_boundary("multipart/form-data; boundary=------------------------d74496d66958873e").value(),
            "------------------------d74496d66958873e");  // curl's shape
}

TEST(MultipartBoundary, AcceptsSeventyCharactersAndRejectsSeventyOne) {
  const std::string seventy(70, 'b');
  EXPECT_EQ(multipart_boundary("multipart/form-data; boundary=" + seventy).value(), seventy);
  const auto too_long = multipart_boundary("multipart/form-data; boundary=" + seventy + "b");
  ASSERT_FALSE(too_long.ok());
  EXPECT_EQ(too_long.error().code(), errc::invalid_input);
}

TEST(MultipartBoundary, RejectsMissingEmptyAndInvalidBoundaries) {
  for (const std::string content_type : {
           "multipart/form-data",
           "multipart/form-data; boundary=",
           "multipart/form-data; boundary=\"\"",
           "multipart/form-data; boundary=\"ab\r\ncd\"",
           "multipart/form-data; boundary=\"ab\ncd\"",
           "multipart/form-data; boundary=\"trailing \"",
           "multipart/form-data; boundary=semi{brace}",
           "multipart/form-data; boundary=\"unterminated",
           "multipart/form-data; boundary=a; boundary=b",
           "multipart/form-data; =a",
       }) {
    const auto boundary_result = multipart_boundary(content_type);
    ASSERT_FALSE(boundary_result.ok()) << content_type;
    EXPECT_EQ(boundary_result.error().code(), errc::invalid_input) << content_type;
    EXPECT_TRUE(is_multipart_form_data(content_type)) << "400, not 415: " << content_type;
  }
}

TEST(MultipartBoundary, OtherMediaTypesAreNotMultipartFormData) {
  for (const std::string content_type :
       {"application/json", "", "multipart/mixed; boundary=abc", "text/plain", "multipart/form-datax; boundary=a"}) {
    EXPECT_FALSE(is_multipart_form_data(content_type)) << content_type;
    const auto boundary_result = multipart_boundary(content_type);
    ASSERT_FALSE(boundary_result.ok());
    EXPECT_EQ(boundary_result.error().message(), "Content-Type is not multipart/form-data");
  }
}

TEST(MultipartBoundary, ValidatesBoundaryCharacters) {
  EXPECT_TRUE(is_valid_boundary("'()+_,-./:=?azAZ09"));
  EXPECT_TRUE(is_valid_boundary("with space"));
  EXPECT_FALSE(is_valid_boundary(""));
  EXPECT_FALSE(is_valid_boundary("ends with space "));
  EXPECT_FALSE(is_valid_boundary(std::string("nul\0byte", 8)));
  EXPECT_FALSE(is_valid_boundary("quote\"d"));
}

// ---- Parsing: valid bodies and chunking (item 15, 18) --------------------------------------------------------

TEST(MultipartParser, ParsesARealisticUploadWhole) {
  const auto form = realistic_form();
  const parse_outcome outcome = parse_whole(build_body(form));
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  expect_same_parts(outcome.parts, form);
  EXPECT_GT(outcome.parts[0].body.size(), 1000u);
}

TEST(MultipartParser, ChunkSizesOneThreeSevenTwentyGiveIdenticalParts) {
  const auto form = realistic_form();
  const std::string body = build_body(form);
  const parse_outcome whole = parse_whole(body);
  ASSERT_TRUE(whole.result.ok());
  for (const std::size_t chunk : {1u, 3u, 7u, 20u, 4096u}) {
    const parse_outcome chunked = parse_in_chunks(body, chunk);
    ASSERT_TRUE(chunked.result.ok()) << "chunk " << chunk << ": " << chunked.result.message();
    EXPECT_TRUE(same_parts(chunked.parts, whole.parts)) << "chunk " << chunk;
  }
}

TEST(MultipartParser, EverySplitPointInTwoChunksGivesIdenticalParts) {
  const std::vector<form_part> form = {
      {"pqr", "x.pqr", "text/plain", "ATOM 1\r\n--" + std::string(boundary.substr(0, 10)) + "\r\n\r\n-\r"},
      {"d", std::nullopt, "", "-1"},
  };
  const std::string body = build_body(form);
  for (std::size_t split = 0; split <= body.size(); ++split) {
    multipart_parser parser{std::string(boundary)};
    ASSERT_TRUE(parser.feed(std::string_view(body).substr(0, split)).ok());
    ASSERT_TRUE(parser.feed(std::string_view(body).substr(split)).ok());
    ASSERT_TRUE(parser.finish().ok()) << "split at " << split;
    expect_same_parts(parser.parts(), form);
  }
}

TEST(MultipartParser, BoundaryLookalikesInsideThePayloadAreData) {
  const std::string b(boundary);
  // Every proper prefix of the delimiter, the boundary without its leading CRLF, a CR-heavy payload.
  std::string payload = "--" + b + " at line start is data\r\n";
  for (std::size_t length = 1; length < b.size() + 4; ++length) {
    payload += ("\r\n--" + b).substr(0, length) + "x";
  }
  payload += "\r\r\n\n\r\n-\r\n--\r\n--X" + b.substr(1) + "\r\nend";
  const std::vector<form_part> form = {{"pqr", "m.pqr", "", payload}, {"t0", std::nullopt, "", "1"}};
  const std::string body = build_body(form);
  for (const std::size_t chunk : {1u, 2u, 3u, 5u, 7u, 20u, 1000u}) {
    const parse_outcome outcome = parse_in_chunks(body, chunk);
    ASSERT_TRUE(outcome.result.ok()) << "chunk " << chunk << ": " << outcome.result.message();
    expect_same_parts(outcome.parts, form);
  }
}

TEST(MultipartParser, CrlfPqrPayloadRoundTrips) {
  std::string pqr = read_file(testing::molecule_path("gly.pqr"));
  std::string crlf;
  for (const char c : pqr) crlf += (c == '\n') ? std::string("\r\n") : std::string(1, c);
  const std::vector<form_part> form = {{"pqr", "gly.pqr", "", crlf}};
  const parse_outcome outcome = parse_in_chunks(build_body(form), 3);
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  expect_same_parts(outcome.parts, form);
}

TEST(MultipartParser, EmptyBodiesAndEmptyFilenameAreKept) {
  const std::vector<form_part> form = {{"empty", std::nullopt, "", ""}, {"pqr", "", "", ""}};
  const parse_outcome outcome = parse_in_chunks(build_body(form), 1);
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  expect_same_parts(outcome.parts, form);
}

TEST(MultipartParser, PreambleAndEpilogueAreIgnored) {
  const std::vector<form_part> form = {{"format", std::nullopt, "", "off"}};
  const std::string body = "This is the preamble.\r\n" + build_body(form) +
                           "epilogue bytes, even --" + std::string(boundary) + "\r\nContent-Disposition: x\r\n";
  for (const std::size_t chunk : {1u, 7u, 1000u}) {
    const parse_outcome outcome = parse_in_chunks(body, chunk);
    ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
    expect_same_parts(outcome.parts, form);
  }
}

TEST(MultipartParser, FinalBoundaryWithoutTrailingCrlfAndWithPaddingIsAccepted) {
  const std::string b(boundary);
  const std::string body = "--" + b + " \t\r\nContent-Disposition: form-data; name=a\r\n\r\n1\r\n--" + b + "--";
  const parse_outcome outcome = parse_in_chunks(body, 1);
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  ASSERT_EQ(outcome.parts.size(), 1u);
  EXPECT_EQ(outcome.parts[0].name, "a");
  EXPECT_EQ(outcome.parts[0].body, "1");
}

TEST(MultipartParser, HeaderSyntaxVariantsAreUnderstood) {
  const std::string b(boundary);
  const std::string body = "--" + b + "\r\n" +
                           "content-disposition: FORM-DATA; filename=\"C:\\dir\\a \\\"b\\\".pqr\";name=pqr\r\n" +
                           "X-Ignored: whatever\r\n" + "CONTENT-TYPE:   chemical/x-pqr  \r\n\r\n" + "ATOM\r\n--" + b +
                           "--\r\n";
  const parse_outcome outcome = parse_in_chunks(body, 1);
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  ASSERT_EQ(outcome.parts.size(), 1u);
  EXPECT_EQ(outcome.parts[0].name, "pqr");
  EXPECT_EQ(outcome.parts[0].filename, std::optional<std::string>("C:\\dir\\a \"b\".pqr"));
  EXPECT_EQ(outcome.parts[0].content_type, "chemical/x-pqr");
  EXPECT_EQ(outcome.parts[0].body, "ATOM");
}

TEST(MultipartParser, BodySizeHintNeverChangesTheResult) {
  const auto form = realistic_form();
  const std::string body = build_body(form);
  for (const std::size_t hint : {std::size_t{0}, std::size_t{10}, body.size(), body.size() * 100}) {
    multipart_parser parser{std::string(boundary)};
    parser.set_body_size_hint(hint);
    for (std::size_t pos = 0; pos < body.size(); pos += 333) {
      ASSERT_TRUE(parser.feed(std::string_view(body).substr(pos, 333)).ok());
    }
    ASSERT_TRUE(parser.finish().ok());
    expect_same_parts(parser.parts(), form);
    EXPECT_LE(parser.parts()[0].body.capacity(), std::max(body.size() * 100, form[0].body.size() * 2))
        << "reserve is bounded by the hint";
  }
}

// ---- Malformed bodies (item 17): distinct errors ----------------------------------------------------------

struct malformed_case {
  std::string label;
  std::string body;
  std::string message_fragment;
};

std::string part_with_headers(const std::string& headers) {
  const std::string b(boundary);
  return "--" + b + "\r\n" + headers + "\r\n" + "data\r\n--" + b + "--\r\n";
}

TEST(MultipartParser, MalformedBodiesFailWithDistinctMessagesWhateverTheChunking) {
  const std::string b(boundary);
  const std::string valid_part = "--" + b + "\r\nContent-Disposition: form-data; name=\"a\"\r\n\r\n1";
  const std::vector<malformed_case> cases = {
      {"empty body", "", "no multipart boundary found"},
      {"wrong boundary", build_body({{"a", std::nullopt, "", "1"}}, "other"), "no multipart boundary found"},
      {"missing final boundary", valid_part, "missing final multipart boundary"},
      {"missing final boundary after a boundary line", valid_part + "\r\n--" + b + "\r\n",
       "ended inside the headers"},
      {"ends right after a boundary", valid_part + "\r\n--" + b, "missing final multipart boundary"},
      {"header without colon", part_with_headers("Content-Disposition form-data; name=a\r\n"), "without a colon"},
      {"empty part headers", part_with_headers(""), "without a Content-Disposition"},
      {"no content-disposition", part_with_headers("Content-Type: text/plain\r\n"), "without a Content-Disposition"},
      {"not form-data", part_with_headers("Content-Disposition: attachment; name=a\r\n"), "not Content-Disposition"},
      {"no name", part_with_headers("Content-Disposition: form-data; filename=a\r\n"), "without a name"},
      {"repeated name", part_with_headers("Content-Disposition: form-data; name=a; name=b\r\n"), "repeats"},
      {"two dispositions",
       part_with_headers("Content-Disposition: form-data; name=a\r\nContent-Disposition: form-data; name=b\r\n"),
       "two Content-Disposition"},
      {"bad disposition params", part_with_headers("Content-Disposition: form-data; name\r\n"), "malformed"},
      {"folded header", part_with_headers("Content-Disposition: form-data;\r\n name=a\r\n"), "folded"},
      {"bad header name", part_with_headers("Content Disposition: form-data; name=a\r\n"), "header name"},
      {"empty header name", part_with_headers(": x\r\nContent-Disposition: form-data; name=a\r\n"), "header name"},
      {"control char in value", part_with_headers(std::string("Content-Disposition: form-data; name=a\x01\r\n")),
       "control character"},
      {"bare LF in headers", "--" + b + "\r\nContent-Disposition: form-data; name=a\n\r\n1\r\n--" + b + "--",
       "bare LF"},
      {"bare CR in headers", "--" + b + "\r\nContent-Disposition: form-data; name=a\rx\r\n\r\n1\r\n--" + b + "--",
       "bare CR"},
      {"boundary followed by garbage", valid_part + "\r\n--" + b + "X\r\n", "unexpected bytes after"},
      {"half close delimiter", valid_part + "\r\n--" + b + "-X", "malformed final"},
      {"bare CR after boundary", "--" + b + "\rX", "bare CR after"},
  };
  for (const malformed_case& test : cases) {
    for (const std::size_t chunk : {1u, 3u, 7u, 100000u}) {
      const parse_outcome outcome = parse_in_chunks(test.body, chunk);
      ASSERT_FALSE(outcome.result.ok()) << test.label;
      EXPECT_EQ(outcome.result.code(), errc::invalid_input) << test.label;
      EXPECT_NE(outcome.result.message().find(test.message_fragment), std::string::npos)
          << test.label << ": " << outcome.result.message();
    }
  }
}

TEST(MultipartParser, ErrorsAreSticky) {
  multipart_parser parser{std::string(boundary)};
  const status first = parser.feed("--" + std::string(boundary) + "\r\nno colon here\r\n\r\n");
  ASSERT_FALSE(first.ok());
  const status later = parser.feed("--" + std::string(boundary) + "--\r\n");
  EXPECT_EQ(later.code(), first.code());
  EXPECT_EQ(later.message(), first.message());
  EXPECT_EQ(parser.finish().message(), first.message());
}

TEST(MultipartParser, InvalidBoundaryMakesEveryFeedFail) {
  multipart_parser parser{""};
  EXPECT_EQ(parser.feed("--\r\n").code(), errc::invalid_input);
  EXPECT_EQ(parser.finish().code(), errc::invalid_input);
}

TEST(MultipartParser, SeventyCharacterBoundaryWorksInChunks) {
  const std::string b(70, '-');
  const std::vector<form_part> form = {{"pqr", "a.pqr", "", std::string(b) + "\r\n-" + b.substr(0, 69)}};
  const parse_outcome outcome = parse_in_chunks(build_body(form, b), 3, {}, b);
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  expect_same_parts(outcome.parts, form);
}

// ---- Limits (item 17 over-long headers, item 21) -------------------------------------------------------------

TEST(MultipartParser, FieldAndFileLimitsAreIndependentAndExact) {
  multipart_limits limits;
  limits.max_field_bytes = 10;
  limits.max_file_bytes = 100;
  const auto parse = [&](const std::vector<form_part>& form) { return parse_in_chunks(build_body(form), 7, limits); };

  EXPECT_TRUE(parse({{"f", std::nullopt, "", std::string(10, 'x')}}).result.ok());
  const auto field_over = parse({{"f", std::nullopt, "", std::string(11, 'x')}});
  EXPECT_EQ(field_over.result.code(), errc::limit_exceeded);
  EXPECT_NE(field_over.result.message().find("max_field_bytes"), std::string::npos);

  EXPECT_TRUE(parse({{"pqr", "a", "", std::string(100, 'x')}}).result.ok());
  const auto file_over = parse({{"pqr", "a", "", std::string(101, 'x')}});
  EXPECT_EQ(file_over.result.code(), errc::limit_exceeded);
  EXPECT_NE(file_over.result.message().find("max_file_bytes"), std::string::npos);
  EXPECT_NE(file_over.result.message().find("'pqr'"), std::string::npos);
}

TEST(MultipartParser, PartCountLimit) {
  multipart_limits limits;
  limits.max_parts = 3;
  std::vector<form_part> form(3, {"f", std::nullopt, "", "1"});
  EXPECT_TRUE(parse_whole(build_body(form), limits).result.ok());
  form.push_back(form.back());
  const auto over = parse_whole(build_body(form), limits);
  EXPECT_EQ(over.result.code(), errc::limit_exceeded);
  EXPECT_EQ(over.parts.size(), 3u);
}

TEST(MultipartParser, OverLongPartHeadersAreRejected) {
  multipart_limits limits;
  limits.max_part_header_bytes = 200;
  const std::string long_value(300, 'v');
  for (const std::string& headers : {"Content-Disposition: form-data; name=\"" + long_value + "\"\r\n",
                                     "X-" + long_value + ": 1\r\nContent-Disposition: form-data; name=a\r\n",
                                     [] {
                                       std::string many = "Content-Disposition: form-data; name=a\r\n";
                                       for (int i = 0; i < 40; ++i) many += "X-A: 1\r\n";
                                       return many;
                                     }()}) {
    const auto outcome = parse_in_chunks(part_with_headers(headers), 5, limits);
    EXPECT_EQ(outcome.result.code(), errc::limit_exceeded) << outcome.result.message();
    EXPECT_NE(outcome.result.message().find("headers exceed 200 bytes"), std::string::npos);
  }
  // Endless transport padding after a boundary counts too.
  const auto padded = parse_in_chunks("--" + std::string(boundary) + std::string(1000, ' '), 9, limits);
  EXPECT_EQ(padded.result.code(), errc::limit_exceeded);
}

// ---- Linear time on large bodies ---------------------------------------------------------------------------

TEST(MultipartParser, LargeAdversarialBodyParsesInLinearTime) {
  // 16 MB of near-delimiters: every byte sits inside a partial match, the worst case for a restarting search.
  const std::string b(boundary);
  const std::string near_miss = "\r\n--" + b.substr(0, b.size() - 1) + "X";
  std::string payload;
  while (payload.size() < (16u << 20)) payload += near_miss;
  const std::string body = build_body({{"pqr", "big.pqr", "", payload}});
  const auto start = std::chrono::steady_clock::now();
  const parse_outcome outcome = parse_in_chunks(body, 65536);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(outcome.result.ok()) << outcome.result.message();
  ASSERT_EQ(outcome.parts.size(), 1u);
  EXPECT_TRUE(outcome.parts[0].body == payload);
  std::printf("adversarial body: %.1f MB in %.3f s (%.0f MB/s)\n", body.size() / 1e6, seconds,
              body.size() / 1e6 / seconds);
}

}  // namespace
}  // namespace tracemesh::server
