// SPDX-License-Identifier: Apache-2.0
// CIDR ranges (--trusted_proxies): parsing is strict and names the entry at fault, and matching
// works bit by bit for both families. The expected values are worked out by hand.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/transport/cidr.h"

namespace scanprep::testing {
namespace {

using server::Cidr;
using server::ParseCidr;
using server::ParseCidrList;
using server::ParseIpAddress;
using ::testing::HasSubstr;

server::IpAddress Ip(absl::string_view text) {
  const auto address = ParseIpAddress(text);
  EXPECT_TRUE(address.has_value()) << text;
  return address.value_or(server::IpAddress{});
}

Cidr Range(absl::string_view text) {
  auto cidr = ParseCidr(text);
  EXPECT_TRUE(cidr.ok()) << cidr.status();
  return cidr.value_or(Cidr{});
}

TEST(Cidr, MatchesTheAddressesWithinItsPrefixOnly) {
  const Cidr ten = Range("10.0.0.0/8");
  EXPECT_TRUE(ten.Contains(Ip("10.0.0.0")));
  EXPECT_TRUE(ten.Contains(Ip("10.255.255.255")));
  EXPECT_FALSE(ten.Contains(Ip("11.0.0.0")));
  EXPECT_FALSE(ten.Contains(Ip("9.255.255.255")));
  // A prefix that ends inside a byte: 192.168.4.0/22 is 192.168.4.0 .. 192.168.7.255.
  const Cidr odd = Range("192.168.4.0/22");
  EXPECT_TRUE(odd.Contains(Ip("192.168.4.1")));
  EXPECT_TRUE(odd.Contains(Ip("192.168.7.255")));
  EXPECT_FALSE(odd.Contains(Ip("192.168.8.0")));
  EXPECT_FALSE(odd.Contains(Ip("192.168.3.255")));
  EXPECT_TRUE(Range("0.0.0.0/0").Contains(Ip("203.0.113.9")));
  EXPECT_TRUE(Range("203.0.113.9").Contains(Ip("203.0.113.9")));  // a single host
  EXPECT_FALSE(Range("203.0.113.9").Contains(Ip("203.0.113.8")));

  const Cidr ula = Range("fd00::/8");
  EXPECT_TRUE(ula.Contains(Ip("fd12:3456::1")));
  EXPECT_FALSE(ula.Contains(Ip("fe80::1")));
  const Cidr v6 = Range("2001:db8:abcd:12::/63");  // ...:12:: .. ...:13:ffff:...
  EXPECT_TRUE(v6.Contains(Ip("2001:db8:abcd:13::5")));
  EXPECT_FALSE(v6.Contains(Ip("2001:db8:abcd:14::")));
  EXPECT_FALSE(Range("::/0").Contains(Ip("10.0.0.1")));  // the families never mix
  EXPECT_FALSE(Range("0.0.0.0/0").Contains(Ip("::1")));
}

TEST(Cidr, AnIpv4MappedIpv6AddressIsTheIpv4Address) {
  EXPECT_EQ(Ip("::ffff:10.1.2.3"), Ip("10.1.2.3"));
  EXPECT_TRUE(Range("10.0.0.0/8").Contains(Ip("::ffff:10.1.2.3")));
  EXPECT_EQ(server::FormatIpAddress(Ip("::ffff:10.1.2.3")), "10.1.2.3");
  EXPECT_EQ(server::FormatIpAddress(Ip("2001:0db8:0000::0001")), "2001:db8::1");
}

TEST(Cidr, ParsingIsStrictAndNamesTheEntry) {
  for (const char* bad : {"", "10.0.0.0/", "10.0.0.0/33", "10.0.0.0/-1", "10.0.0.0/+8",
                          "10.0.0.0/ 8", "10.0.0/8", "10.0.0.256", "::/129", "[::1]",
                          "fe80::1%eth0", "host.example", "10.0.0.0/8/8", "10.0.0.0/0x8"}) {
    EXPECT_EQ(ParseCidr(bad).status().code(), absl::StatusCode::kInvalidArgument) << bad;
  }
  EXPECT_THAT(ParseCidr("10.0.0.1/8").status().message(),
              HasSubstr("'10.0.0.1/8' has address bits set beyond its /8 prefix; the range is "
                        "10.0.0.0/8"));
  EXPECT_THAT(ParseCidr("10.0.0.0/33").status().message(),
              HasSubstr("the prefix length must be 0 to 32 for an IPv4 address"));

  auto list = ParseCidrList(" 10.0.0.0/8, fd00::/8 ,192.168.1.1");
  ASSERT_TRUE(list.ok()) << list.status();
  ASSERT_EQ(list->size(), 3u);
  EXPECT_EQ((*list)[2].prefix_bits, 32);
  EXPECT_TRUE(ParseCidrList("").ok() && ParseCidrList("")->empty());
  EXPECT_THAT(ParseCidrList("10.0.0.0/8,,fd00::/8").status().message(), HasSubstr("''"));
  EXPECT_THAT(ParseCidrList("10.0.0.0/8,10.0.0.0/40").status().message(),
              HasSubstr("'10.0.0.0/40'"));
}

}  // namespace
}  // namespace scanprep::testing
