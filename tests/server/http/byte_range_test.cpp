// Range / If-Range decisions (RFC 9110 §14) for one representation.
#include "server/http/byte_range.hpp"

#include <gtest/gtest.h>

namespace tracemesh::server {
namespace {

const std::string etag = "\"abc-off\"";

range_decision decide(const char* range, std::uint64_t size = 1000, std::optional<std::string_view> if_range = {}) {
  return decide_range(std::optional<std::string_view>(range), if_range, etag, size);
}

void expect_partial(const range_decision& d, std::uint64_t first, std::uint64_t length) {
  ASSERT_EQ(d.outcome, range_outcome::partial);
  EXPECT_EQ(d.range.first, first);
  EXPECT_EQ(d.range.length, length);
}

TEST(DecideRange, NoRangeIsFull) {
  EXPECT_EQ(decide_range(std::nullopt, std::nullopt, etag, 10).outcome, range_outcome::full);
}

TEST(DecideRange, OneRangeOfEachShapeIsClippedToTheLength) {
  expect_partial(decide("bytes=0-99"), 0, 100);
  expect_partial(decide("bytes=900-"), 900, 100);
  expect_partial(decide("bytes=900-5000"), 900, 100);
  expect_partial(decide("bytes=-10"), 990, 10);
  expect_partial(decide("bytes=-5000"), 0, 1000);
  expect_partial(decide("bytes=999-999"), 999, 1);
  expect_partial(decide("Bytes= 5-9 "), 5, 5);
}

TEST(DecideRange, UnsatisfiableRangesAre416) {
  EXPECT_EQ(decide("bytes=1000-").outcome, range_outcome::unsatisfiable);
  EXPECT_EQ(decide("bytes=1000-2000").outcome, range_outcome::unsatisfiable);
  EXPECT_EQ(decide("bytes=-0").outcome, range_outcome::unsatisfiable);
  EXPECT_EQ(decide("bytes=0-", 0).outcome, range_outcome::unsatisfiable);
  EXPECT_EQ(decide("bytes=-5", 0).outcome, range_outcome::unsatisfiable);
}

TEST(DecideRange, MalformedOtherUnitsAndSeveralRangesAreServedWhole) {
  for (const char* field : {"bytes=5-3", "bytes=a-b", "bytes=", "bytes=-", "bytes=1", "items=0-5", "bytes 0-5",
                            "bytes=0-5,10-20", "bytes=0-5, 1000-", "bytes=99999999999999999999-",
                            "bytes=--5", "bytes=+1-2"}) {
    EXPECT_EQ(decide(field).outcome, range_outcome::full) << field;
  }
}

TEST(DecideRange, IfRangeNeedsTheSameStrongEtag) {
  expect_partial(decide("bytes=0-9", 1000, etag), 0, 10);
  expect_partial(decide("bytes=0-9", 1000, " \"abc-off\" "), 0, 10);
  EXPECT_EQ(decide("bytes=0-9", 1000, "\"abc-ply\"").outcome, range_outcome::full);
  EXPECT_EQ(decide("bytes=0-9", 1000, "W/\"abc-off\"").outcome, range_outcome::full);
  EXPECT_EQ(decide("bytes=0-9", 1000, "Wed, 25 Nov 2026 17:00:00 GMT").outcome, range_outcome::full);
  // A mismatching If-Range sends the whole representation even for an unsatisfiable range.
  EXPECT_EQ(decide("bytes=5000-", 1000, "\"old\"").outcome, range_outcome::full);
}

TEST(ContentRange, PartialAndUnsatisfiableValues) {
  EXPECT_EQ(content_range(decide("bytes=10-19"), 1000), "bytes 10-19/1000");
  EXPECT_EQ(content_range(decide("bytes=-1"), 1000), "bytes 999-999/1000");
  EXPECT_EQ(content_range(decide("bytes=2000-"), 1000), "bytes */1000");
}

}  // namespace
}  // namespace tracemesh::server
