// SPDX-License-Identifier: Apache-2.0
#include "server/transport/client_identity.h"

#include <grpcpp/server_context.h>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace scanprep::server {

std::optional<IpAddress> PeerAddress(absl::string_view peer) {
  // gRPC writes IP peers as ipv4:ADDR:PORT and ipv6:[ADDR]:PORT (or %5BADDR%5D:PORT), always
  // with the port.
  if (!absl::ConsumePrefix(&peer, "ipv4:") && !absl::ConsumePrefix(&peer, "ipv6:")) {
    return std::nullopt;
  }
  const size_t colon = peer.rfind(':');
  if (colon == absl::string_view::npos) return std::nullopt;
  peer = peer.substr(0, colon);
  if (!(absl::ConsumePrefix(&peer, "[") && absl::ConsumeSuffix(&peer, "]"))) {
    absl::ConsumePrefix(&peer, "%5B") && absl::ConsumeSuffix(&peer, "%5D");
  }
  return ParseIpAddress(peer);
}

std::string ClientHost(absl::string_view peer, const std::vector<absl::string_view>& forwarded_for,
                       const std::vector<Cidr>& trusted_proxies) {
  const std::optional<IpAddress> direct = PeerAddress(peer);
  if (!direct) return std::string(peer);
  IpAddress client = *direct;
  std::vector<absl::string_view> hops;
  for (absl::string_view header : forwarded_for) {
    for (absl::string_view hop : absl::StrSplit(header, ',')) {
      hops.push_back(absl::StripAsciiWhitespace(hop));
    }
  }
  // `client` is a trusted proxy here, so the hop it appended is believed.
  for (auto hop = hops.rbegin(); hop != hops.rend() && AnyContains(trusted_proxies, client);
       ++hop) {
    const std::optional<IpAddress> address = ParseIpAddress(*hop);
    if (!address) break;
    client = *address;
  }
  return FormatIpAddress(client);
}

std::string ClientHost(const grpc::ServerContext& context,
                       const std::vector<Cidr>& trusted_proxies) {
  std::vector<absl::string_view> forwarded_for;
  // gRPC keeps metadata keys lower-case and the headers in the order they arrived.
  const auto [begin, end] = context.client_metadata().equal_range("x-forwarded-for");
  for (auto it = begin; it != end; ++it) {
    forwarded_for.emplace_back(it->second.data(), it->second.size());
  }
  return ClientHost(context.peer(), forwarded_for, trusted_proxies);
}

}  // namespace scanprep::server
