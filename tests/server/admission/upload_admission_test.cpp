// Tests of server/admission/upload_admission.hpp: the count and byte bounds of uploads in flight.
#include "server/admission/upload_admission.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <thread>
#include <vector>

namespace tracemesh::server {
namespace {

TEST(UploadAdmission, BoundsTheNumberOfUploads) {
  upload_admission admission(2, 1000);
  auto first = admission.admit(10);
  auto second = admission.admit(10);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(admission.admit(10), nullptr);
  EXPECT_EQ(admission.uploads_in_flight(), 2u);
  first.reset();
  EXPECT_NE(admission.admit(10), nullptr);
}

TEST(UploadAdmission, BoundsTheBytesOfUploadsTogether) {
  upload_admission admission(10, 1000);
  auto big = admission.admit(700);
  ASSERT_TRUE(big);
  EXPECT_EQ(admission.admit(301), nullptr) << "700 + 301 > 1000";
  auto fits = admission.admit(300);
  ASSERT_TRUE(fits);
  EXPECT_EQ(admission.bytes_in_flight(), 1000u);
  EXPECT_EQ(admission.admit(0), nullptr) << "no byte left, even for an upload of unknown size";
  big.reset();
  EXPECT_EQ(admission.bytes_in_flight(), 300u);
  EXPECT_NE(admission.admit(700), nullptr);
}

TEST(UploadAdmission, ALoneUploadIsAdmittedWhateverItsSize) {
  upload_admission admission(4, 100);
  auto huge = admission.admit(5000);
  ASSERT_TRUE(huge) << "one upload over the byte bound is served alone";
  EXPECT_EQ(admission.admit(1), nullptr) << "but nothing joins it";
  EXPECT_TRUE(huge->reserve_total(8000)) << "and it may keep growing while alone";
  huge.reset();
  EXPECT_EQ(admission.bytes_in_flight(), 0u);
  EXPECT_EQ(admission.uploads_in_flight(), 0u);
}

TEST(UploadAdmission, ChunkedUploadsGrowTheirReservation) {
  upload_admission admission(4, 1000);
  auto chunked = admission.admit(0);
  auto other = admission.admit(400);
  ASSERT_TRUE(chunked && other);
  EXPECT_TRUE(chunked->reserve_total(500));
  EXPECT_TRUE(chunked->reserve_total(300)) << "never lowered";
  EXPECT_EQ(chunked->reserved_bytes(), 500u);
  EXPECT_TRUE(chunked->reserve_total(600));
  EXPECT_FALSE(chunked->reserve_total(601)) << "400 + 601 > 1000";
  EXPECT_EQ(chunked->reserved_bytes(), 600u);
  EXPECT_EQ(admission.bytes_in_flight(), 1000u);
  other.reset();
  EXPECT_TRUE(chunked->reserve_total(5000)) << "alone now";
  chunked.reset();
  EXPECT_EQ(admission.bytes_in_flight(), 0u);
}

TEST(UploadAdmission, TicketsMayOutliveTheAdmission) {
  std::shared_ptr<upload_ticket> ticket;
  {
    upload_admission admission(1, 10);
    ticket = admission.admit(5);
  }
  ASSERT_TRUE(ticket);
  EXPECT_TRUE(ticket->reserve_total(7));
  ticket.reset();  // must not touch freed memory (ASan)
}

TEST(UploadAdmission, ConcurrentAdmissionsNeverExceedTheBounds) {
  upload_admission admission(3, 300);
  std::vector<std::thread> threads;
  std::atomic<bool> exceeded{false};
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 2000; ++i) {
        auto ticket = admission.admit(100);
        if (!ticket) continue;
        if (admission.uploads_in_flight() > 3 || admission.bytes_in_flight() > 300) exceeded = true;
        ticket->reserve_total(150);
        if (admission.bytes_in_flight() > 300) exceeded = true;
      }
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_FALSE(exceeded.load());
  EXPECT_EQ(admission.uploads_in_flight(), 0u);
  EXPECT_EQ(admission.bytes_in_flight(), 0u);
}

}  // namespace
}  // namespace tracemesh::server
