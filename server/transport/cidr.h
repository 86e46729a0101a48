// SPDX-License-Identifier: Apache-2.0
// IP addresses and CIDR ranges, IPv4 and IPv6, for telling a trusted proxy from a client
// (--trusted_proxies). An IPv4-mapped IPv6 address (::ffff:a.b.c.d, what a dual-stack listener
// reports for an IPv4 client) is the IPv4 address: one host must not count as two, and
// "10.0.0.0/8" must match it.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace scanprep::server {

struct IpAddress {
  bool v4 = false;
  std::array<uint8_t, 16> bytes{};  // network order; an IPv4 address uses the first 4

  friend bool operator==(const IpAddress&, const IpAddress&) = default;
};

// "10.0.0.7", "2001:db8::1", "::ffff:10.0.0.7" (read as IPv4); nothing else (no brackets, no
// port, no zone).
std::optional<IpAddress> ParseIpAddress(absl::string_view text);

// The canonical text: "10.0.0.7", "2001:db8::1".
std::string FormatIpAddress(const IpAddress& address);

struct Cidr {
  IpAddress network;  // the address with the bits beyond the prefix cleared
  int prefix_bits = 0;

  bool Contains(const IpAddress& address) const;
};

// "10.0.0.0/8", "fd00::/8"; an address without "/N" is the single host (/32, /128). Strict: the
// prefix is a decimal number within the family's width, and no bit beyond it may be set
// ("10.0.0.1/8" is refused: it usually means a typo in the address or the prefix).
absl::StatusOr<Cidr> ParseCidr(absl::string_view text);

// A comma-separated list, spaces around the entries allowed; empty text is the empty list.
// INVALID_ARGUMENT names the entry at fault.
absl::StatusOr<std::vector<Cidr>> ParseCidrList(absl::string_view text);

bool AnyContains(const std::vector<Cidr>& ranges, const IpAddress& address);

}  // namespace scanprep::server
