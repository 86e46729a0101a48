// SPDX-License-Identifier: Apache-2.0
#include "server/transport/cidr.h"

#include <arpa/inet.h>

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/base/status_macros.h"

namespace scanprep::server {
namespace {

constexpr std::array<uint8_t, 12> kV4MappedPrefix = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};

}  // namespace

std::optional<IpAddress> ParseIpAddress(absl::string_view text) {
  // inet_pton needs a terminated string and accepts exactly the plain forms (no port, brackets
  // or zone).
  const std::string s(text);
  IpAddress a;
  if (inet_pton(AF_INET, s.c_str(), a.bytes.data()) == 1) {
    a.v4 = true;
    return a;
  }
  if (inet_pton(AF_INET6, s.c_str(), a.bytes.data()) != 1) return std::nullopt;
  if (std::equal(kV4MappedPrefix.begin(), kV4MappedPrefix.end(), a.bytes.begin())) {
    IpAddress v4{.v4 = true};
    std::copy(a.bytes.begin() + 12, a.bytes.end(), v4.bytes.begin());
    return v4;
  }
  return a;
}

std::string FormatIpAddress(const IpAddress& address) {
  char text[INET6_ADDRSTRLEN] = {};
  inet_ntop(address.v4 ? AF_INET : AF_INET6, address.bytes.data(), text, sizeof text);
  return text;
}

bool Cidr::Contains(const IpAddress& address) const {
  if (address.v4 != network.v4) return false;
  const int full = prefix_bits / 8, rest = prefix_bits % 8;
  if (!std::equal(network.bytes.begin(), network.bytes.begin() + full, address.bytes.begin())) {
    return false;
  }
  if (rest == 0) return true;
  const uint8_t mask = static_cast<uint8_t>(0xff << (8 - rest));
  return (address.bytes[full] & mask) == network.bytes[full];
}

absl::StatusOr<Cidr> ParseCidr(absl::string_view text) {
  const size_t slash = text.find('/');
  const std::optional<IpAddress> address = ParseIpAddress(text.substr(0, slash));
  if (!address) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", text, "' is not an IPv4 or IPv6 address or CIDR range"));
  }
  const int width = address->v4 ? 32 : 128;
  Cidr cidr{.network = *address, .prefix_bits = width};
  if (slash != absl::string_view::npos) {
    const absl::string_view prefix = text.substr(slash + 1);
    // SimpleAtoi would take "+8" and " 8"; a prefix is digits only.
    if (prefix.empty() || prefix.size() > 3 ||
        !std::all_of(prefix.begin(), prefix.end(), absl::ascii_isdigit) ||
        !absl::SimpleAtoi(prefix, &cidr.prefix_bits) || cidr.prefix_bits > width) {
      return absl::InvalidArgumentError(
          absl::StrCat("'", text, "': the prefix length must be 0 to ", width, " for an IPv",
                       address->v4 ? 4 : 6, " address"));
    }
  }
  Cidr cleared = cidr;
  for (int bit = cidr.prefix_bits; bit < width; ++bit) {
    cleared.network.bytes[bit / 8] &= static_cast<uint8_t>(~(0x80 >> (bit % 8)));
  }
  if (cleared.network != cidr.network) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", text, "' has address bits set beyond its /", cidr.prefix_bits,
        " prefix; the range is ", FormatIpAddress(cleared.network), "/", cidr.prefix_bits));
  }
  return cidr;
}

absl::StatusOr<std::vector<Cidr>> ParseCidrList(absl::string_view text) {
  std::vector<Cidr> ranges;
  if (absl::StripAsciiWhitespace(text).empty()) return ranges;
  for (absl::string_view entry : absl::StrSplit(text, ',')) {
    SCANPREP_ASSIGN_OR_RETURN(Cidr cidr, ParseCidr(absl::StripAsciiWhitespace(entry)));
    ranges.push_back(cidr);
  }
  return ranges;
}

bool AnyContains(const std::vector<Cidr>& ranges, const IpAddress& address) {
  return std::any_of(ranges.begin(), ranges.end(),
                     [&](const Cidr& c) { return c.Contains(address); });
}

}  // namespace scanprep::server
