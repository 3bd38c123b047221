// Tests of server/storage/content_hash.hpp: SHA-256 against the FIPS 180-2 example vectors, incremental hashing, and the
// job-id syntax check (service-test-list item 42).
#include "server/storage/content_hash.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>

namespace tracemesh::server {
namespace {

// FIPS 180-2 appendix B: the published digests of three messages.
constexpr std::string_view digest_of_abc = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
constexpr std::string_view two_block_message = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
constexpr std::string_view digest_of_two_block_message =
    "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1";
constexpr std::string_view digest_of_million_a = "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0";
constexpr std::string_view digest_of_empty = "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855";

TEST(Sha256, MatchesPublishedVectors) {
  EXPECT_EQ(sha256_hex(""), digest_of_empty);
  EXPECT_EQ(sha256_hex("abc"), digest_of_abc);
  EXPECT_EQ(sha256_hex(two_block_message), digest_of_two_block_message);
  EXPECT_EQ(sha256_hex(std::string(1'000'000, 'a')), digest_of_million_a);
}

TEST(Sha256, IncrementalUpdatesEqualOneShot) {
  const std::string message(1'000'000, 'a');
  for (const std::size_t piece : {7u, 63u, 64u, 65u, 4096u}) {  // around the 64-byte block size
    sha256 hasher;
    for (std::size_t pos = 0; pos < message.size(); pos += piece) {
      hasher.update(std::string_view(message).substr(pos, piece));
    }
    EXPECT_EQ(hasher.hex_digest(), digest_of_million_a) << "pieces of " << piece;
  }
  sha256 bytewise;  // single bytes, on a short message
  for (const char c : two_block_message) bytewise.update(std::string_view(&c, 1));
  EXPECT_EQ(bytewise.hex_digest(), digest_of_two_block_message);
}

TEST(Sha256, DigestResetsForReuse) {
  sha256 hasher;
  hasher.update("ab");
  hasher.update("c");
  EXPECT_EQ(hasher.hex_digest(), digest_of_abc);
  EXPECT_EQ(hasher.hex_digest(), digest_of_empty);
  hasher.update("abc");
  EXPECT_EQ(hasher.hex_digest(), digest_of_abc);
}

TEST(Sha256, RawDigestMatchesHex) {
  sha256 hasher;
  hasher.update("abc");
  const sha256::digest raw = hasher.finish();
  EXPECT_EQ(to_hex(raw.data(), raw.size()), digest_of_abc);
}

TEST(Sha256, MovedHasherKeepsItsState) {
  sha256 first;
  first.update("a");
  sha256 second = std::move(first);
  second.update("bc");
  EXPECT_EQ(second.hex_digest(), digest_of_abc);
}

TEST(Sha256, DigestsAreValidJobIds) {
  EXPECT_TRUE(is_valid_job_id(sha256_hex("any input")));
  EXPECT_NE(sha256_hex("a"), sha256_hex("b"));
}

TEST(JobId, AcceptsOnlySixtyFourLowerCaseHexDigits) {
  EXPECT_TRUE(is_valid_job_id(digest_of_abc));
  EXPECT_TRUE(is_valid_job_id(std::string(64, '0')));
  EXPECT_TRUE(is_valid_job_id(std::string(64, 'f')));

  const std::string valid(digest_of_abc);
  std::string upper = valid;
  upper[0] = 'B';
  std::string nul = valid;
  nul[10] = '\0';
  std::string fullwidth_a = valid.substr(0, 61) + "\xef\xbd\x81";  // U+FF41, same length in bytes as 3 digits
  for (const std::string& bad : {
           std::string(),
           valid.substr(0, 63),
           valid + "0",
           upper,
           nul,
           fullwidth_a,
           std::string("../") + valid.substr(3),
           std::string("%2e%2e%2f") + valid.substr(9),
           std::string("..%5c") + valid.substr(5),
           std::string("/") + valid.substr(1),
           valid.substr(0, 63) + "g",
           valid.substr(0, 63) + " ",
           valid + ".off",
       }) {
    EXPECT_FALSE(is_valid_job_id(bad)) << bad;
  }
}

TEST(Hex, EncodesEveryByteValue) {
  const std::uint8_t bytes[] = {0x00, 0x0f, 0x10, 0xa5, 0xff};
  EXPECT_EQ(to_hex(bytes, sizeof bytes), "000f10a5ff");
  EXPECT_EQ(to_hex(bytes, 0), "");
}

}  // namespace
}  // namespace tracemesh::server
