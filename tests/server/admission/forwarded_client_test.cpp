// Tests of server/admission/forwarded_client.hpp: --trusted-proxy networks, and the client a trusted proxy's
// Forwarded (RFC 7239) or X-Forwarded-For header names.
#include "server/admission/forwarded_client.hpp"

#include <gtest/gtest.h>

#include <string>
#include <string_view>
#include <vector>

namespace tracemesh::server {
namespace {

std::vector<ip_network> networks(const std::vector<std::string>& values) {
  const auto parsed = parse_networks(values);
  EXPECT_TRUE(parsed.ok()) << parsed.error().message();
  return parsed.ok() ? *parsed : std::vector<ip_network>{};
}

/// The client of a request from `peer` with these Forwarded and X-Forwarded-For fields, 10.0.0.0/8 and fd00::/8
/// trusted.
std::string client_of(const std::string& peer, std::vector<std::string_view> forwarded,
                      std::vector<std::string_view> x_forwarded_for = {}) {
  static const std::vector<ip_network> trusted = networks({"10.0.0.0/8", "fd00::/8"});
  return forwarded_client(peer, forwarded, x_forwarded_for, trusted);
}

TEST(ForwardedClientTest, NetworksParseAsCidrOrSingleAddressesInListsOrRepeated) {
  const std::vector<ip_network> parsed = networks({"10.1.2.3/8, 192.168.0.7", "2001:db8::1/32,::1"});
  ASSERT_EQ(parsed.size(), 4u);
  EXPECT_EQ(parsed[0].to_string(), "10.0.0.0/8") << "bits past the prefix are cleared";
  EXPECT_EQ(parsed[1].to_string(), "192.168.0.7/32");
  EXPECT_EQ(parsed[2].to_string(), "2001:db8::/32");
  EXPECT_EQ(parsed[3].to_string(), "::1/128");
  EXPECT_TRUE(in_networks(parsed, "10.255.0.1"));
  EXPECT_FALSE(in_networks(parsed, "11.0.0.1"));
  EXPECT_TRUE(in_networks(parsed, "192.168.0.7"));
  EXPECT_FALSE(in_networks(parsed, "192.168.0.8"));
  EXPECT_TRUE(in_networks(parsed, "2001:db8:ffff::2"));
  EXPECT_FALSE(in_networks(parsed, "2001:db9::1"));
  EXPECT_TRUE(in_networks(parsed, "::ffff:10.0.0.9")) << "an IPv4-mapped peer is its IPv4 address";
  EXPECT_FALSE(in_networks(parsed, "not an address"));
  EXPECT_TRUE(in_networks(networks({"172.16.0.0/12"}), "172.31.255.255"));
  EXPECT_FALSE(in_networks(networks({"172.16.0.0/12"}), "172.32.0.0"));
  EXPECT_TRUE(in_networks(networks({"0.0.0.0/0"}), "8.8.8.8"));
  EXPECT_FALSE(in_networks(networks({"0.0.0.0/0"}), "::1")) << "an IPv4 network holds no IPv6 address";
}

TEST(ForwardedClientTest, MalformedNetworksAreRefusedNamingTheText) {
  for (const std::string bad : {"10.0.0.0/33", "::/129", "10.0.0.0/", "10.0.0/8", "host.example", "10.0.0.0/8x",
                                "fe80::1%eth0", "10.0.0.0/-1"}) {
    const auto parsed = parse_networks({bad});
    ASSERT_FALSE(parsed.ok()) << bad;
    EXPECT_NE(parsed.error().message().find(bad), std::string::npos) << parsed.error().message();
  }
  EXPECT_TRUE(parse_networks({}).ok());
  EXPECT_TRUE(parse_networks({"10.0.0.1,"}).ok()) << "an empty list element is nothing";
}

TEST(ForwardedClientTest, TheRightmostHopNotATrustedProxyIsTheClient) {
  EXPECT_EQ(client_of("10.0.0.1", {"for=192.0.2.60"}), "192.0.2.60");
  EXPECT_EQ(client_of("10.0.0.1", {"for=192.0.2.60;proto=https;by=10.0.0.1"}), "192.0.2.60");
  EXPECT_EQ(client_of("10.0.0.1", {"For=\"192.0.2.60:4711\""}), "192.0.2.60") << "names are case-insensitive";
  EXPECT_EQ(client_of("10.0.0.1", {"for=\"[2001:db8:cafe::17]:4711\""}), "2001:db8:cafe::17");
  EXPECT_EQ(client_of("10.0.0.1", {"for=\"[2001:db8:cafe::17]\""}), "2001:db8:cafe::17");
  // A forged hop on the client's side stays to the left of the one the trusted proxies saw.
  EXPECT_EQ(client_of("10.0.0.1", {"for=6.6.6.6, for=192.0.2.60, for=10.2.3.4"}), "192.0.2.60");
  EXPECT_EQ(client_of("10.0.0.1", {"for=6.6.6.6", "for=192.0.2.60;proto=http, for=\"[fd00::5]\""}), "192.0.2.60")
      << "several fields are one list, in order";
  EXPECT_EQ(client_of("10.0.0.1", {"for=10.0.0.7, for=10.0.0.8"}), "10.0.0.7")
      << "every hop trusted: the farthest named";
  // X-Forwarded-For when there is no Forwarded field.
  EXPECT_EQ(client_of("10.0.0.1", {}, {"6.6.6.6, 198.51.100.7"}), "198.51.100.7");
  EXPECT_EQ(client_of("10.0.0.1", {}, {"6.6.6.6", "198.51.100.7, 10.9.9.9"}), "198.51.100.7");
  EXPECT_EQ(client_of("10.0.0.1", {}, {"2001:db8::9"}), "2001:db8::9");
  EXPECT_EQ(client_of("10.0.0.1", {}, {"198.51.100.7:5555"}), "198.51.100.7");
  EXPECT_EQ(client_of("10.0.0.1", {}, {"[2001:db8::9]:5555"}), "2001:db8::9");
  EXPECT_EQ(client_of("10.0.0.1", {}, {"::ffff:198.51.100.7"}), "198.51.100.7");
  EXPECT_EQ(client_of("10.0.0.1", {"for=192.0.2.60"}, {"198.51.100.7"}), "192.0.2.60") << "Forwarded first";
  EXPECT_EQ(client_of("fd00::1", {"for=192.0.2.60"}), "192.0.2.60") << "an IPv6 proxy";
}

TEST(ForwardedClientTest, HeadersFromAPeerThatIsNoTrustedProxyAreIgnored) {
  EXPECT_EQ(client_of("192.0.2.1", {"for=198.51.100.7"}), "192.0.2.1");
  EXPECT_EQ(client_of("192.0.2.1", {}, {"198.51.100.7"}), "192.0.2.1");
  EXPECT_EQ(forwarded_client("10.0.0.1", {"for=198.51.100.7"}, {}, {}), "10.0.0.1") << "nothing trusted";
}

TEST(ForwardedClientTest, AnUnreadableHeaderLeavesThePeerAsTheClient) {
  for (const std::string_view bad :
       {"for=unknown", "for=_hidden", "for=\"[2001:db8::1\"", "for=\"192.0.2.60", "for=2001:db8::1:80:1:2:3:4:5",
        "proto=https", "for=", "for=192.0.2", "for=\"[192.0.2.1]\"", "for=192.0.2.1:99999", "garbage", ""}) {
    EXPECT_EQ(client_of("10.0.0.1", {bad}), "10.0.0.1") << bad;
  }
  for (const std::string_view bad : {"198.51.100.7,", "unknown", "198.51.100.7 junk", "[2001:db8::1", ""}) {
    EXPECT_EQ(client_of("10.0.0.1", {}, {bad}), "10.0.0.1") << bad;
  }
  EXPECT_EQ(client_of("10.0.0.1", {}, {}), "10.0.0.1") << "no header";
  // Only the hops up to the client are read: garbage a client put to its left does not matter.
  EXPECT_EQ(client_of("10.0.0.1", {"for=unknown, for=192.0.2.60"}), "192.0.2.60");
  EXPECT_EQ(client_of("10.0.0.1", {}, {"garbage, 198.51.100.7"}), "198.51.100.7");
  EXPECT_EQ(client_of("10.0.0.1", {"for=\"a,b\";proto=x, for=192.0.2.60"}), "192.0.2.60")
      << "a comma inside a quoted string separates nothing";
}

}  // namespace
}  // namespace tracemesh::server
