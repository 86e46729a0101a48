// SPDX-License-Identifier: Apache-2.0
// The client host a call is counted as: the direct peer without its port, and x-forwarded-for
// believed only as far as trusted proxies vouch for it (each one's forwarded address, from the
// right). The expected values are worked out by hand from the addresses.
#include <gtest/gtest.h>

#include "server/transport/cidr.h"
#include "server/transport/client_identity.h"

namespace scanprep::testing {
namespace {

using server::Cidr;
using server::ClientHost;

Cidr Range(absl::string_view text) {
  auto cidr = server::ParseCidr(text);
  EXPECT_TRUE(cidr.ok()) << cidr.status();
  return cidr.value_or(Cidr{});
}

TEST(ClientIdentity, TheDirectPeerWithoutItsPort) {
  const std::vector<Cidr> none;
  EXPECT_EQ(ClientHost("ipv4:10.0.0.7:51234", {}, none), "10.0.0.7");
  EXPECT_EQ(ClientHost("ipv6:[::1]:51234", {}, none), "::1");
  EXPECT_EQ(ClientHost("ipv6:%5B::1%5D:51234", {}, none), "::1");
  EXPECT_EQ(ClientHost("ipv6:[::ffff:127.0.0.1]:8", {}, none), "127.0.0.1");
  EXPECT_EQ(ClientHost("unix:/run/scanprep.sock", {}, none), "unix:/run/scanprep.sock");
}

TEST(ClientIdentity, AForwardedAddressCountsOnlyFromATrustedProxy) {
  const std::vector<Cidr> proxies = {Range("10.0.0.0/8"), Range("fd00::/8")};
  // The control: a peer outside the trusted ranges writes what it likes; it is the client.
  EXPECT_EQ(ClientHost("ipv4:198.51.100.4:5000", {"203.0.113.7"}, proxies), "198.51.100.4");
  EXPECT_EQ(ClientHost("ipv4:198.51.100.4:5000", {"203.0.113.7"}, {}), "198.51.100.4");
  // A trusted proxy's forwarded address is the client.
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {"203.0.113.7"}, proxies), "203.0.113.7");
  EXPECT_EQ(ClientHost("ipv6:[fd00::2]:5000", {"2001:db8::9"}, proxies), "2001:db8::9");
  // From the right, past every trusted hop, to the first address that is not one: what the
  // client wrote itself (the left-most 1.2.3.4) is not believed.
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {"1.2.3.4, 203.0.113.7, 10.2.2.2"}, proxies),
            "203.0.113.7");
  // Several headers are one list, in order.
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {"1.2.3.4, 203.0.113.7", "10.2.2.2"}, proxies),
            "203.0.113.7");
  // Only trusted hops: the left-most.
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {"10.3.3.3, 10.2.2.2"}, proxies), "10.3.3.3");
  // A hop that is not an address: the trusted proxy that wrote it is the client.
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {"203.0.113.7, unknown"}, proxies), "10.1.1.1");
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {"unknown, 10.2.2.2"}, proxies), "10.2.2.2");
  // No header: the proxy itself.
  EXPECT_EQ(ClientHost("ipv4:10.1.1.1:5000", {}, proxies), "10.1.1.1");
}

}  // namespace
}  // namespace scanprep::testing
