// Tests of server/admission/client_quota.hpp: a per-client bound on uses held at once.
#include "server/admission/client_quota.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

namespace tracemesh::server {
namespace {

TEST(ClientQuota, BoundsEachClientApart) {
  client_quota quota(2);
  auto a1 = quota.acquire("ip:10.0.0.1");
  auto a2 = quota.acquire("ip:10.0.0.1");
  ASSERT_TRUE(a1 && a2);
  EXPECT_EQ(quota.acquire("ip:10.0.0.1"), nullptr) << "a third use by the same client";
  EXPECT_NE(quota.acquire("ip:10.0.0.2"), nullptr) << "another client is not affected";
  EXPECT_EQ(quota.held("ip:10.0.0.1"), 2u);
  a1.reset();
  EXPECT_EQ(quota.held("ip:10.0.0.1"), 1u);
  EXPECT_NE(quota.acquire("ip:10.0.0.1"), nullptr) << "a released use frees a slot";
}

TEST(ClientQuota, LeasesMayOutliveTheQuotaAndZeroRefusesAll) {
  std::shared_ptr<client_lease> lease;
  {
    client_quota quota(1);
    lease = quota.acquire("token:abc");
    ASSERT_TRUE(lease);
  }
  lease.reset();  // no use-after-free (ASan)
  client_quota none(0);
  EXPECT_EQ(none.acquire("ip:10.0.0.1"), nullptr);
  EXPECT_EQ(none.held("ip:10.0.0.1"), 0u);
}

}  // namespace
}  // namespace tracemesh::server
