// SPDX-License-Identifier: Apache-2.0
// Which client host a call comes from, the key of the admission queue's fairness and of the
// optional per-host cap. The direct peer's address, without its port (which changes with every
// connection); behind a proxy every call has the proxy's address, so when the direct peer is in
// --trusted_proxies the address it forwarded in `x-forwarded-for` counts instead: read from the
// right (each proxy appends the address it received the call from), the first address that is not
// itself a trusted proxy. A client can write any x-forwarded-for it likes, so the header is
// believed only as far as trusted proxies vouch for it.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/strings/string_view.h"
#include "server/transport/cidr.h"

namespace grpc {
class ServerContext;
}  // namespace grpc

namespace scanprep::server {

// The address in gRPC's peer string: "ipv4:10.0.0.7:51234" -> 10.0.0.7, "ipv6:[::1]:51234" and
// "ipv6:%5B::1%5D:51234" -> ::1; nothing for peers that are not IP addresses (unix:PATH).
std::optional<IpAddress> PeerAddress(absl::string_view peer);

// The client host of a call from `peer` that carried the x-forwarded-for values `forwarded_for`
// (one per header, each a comma-separated list, oldest hop first): the canonical address text
// ("10.0.0.7", "::1"), or the peer string as it is when it is not an IP address. A forwarded
// entry that is not an IP address ("unknown", an obfuscated RFC 7239 name) ends the walk: the
// trusted proxy that wrote it is the client.
std::string ClientHost(absl::string_view peer, const std::vector<absl::string_view>& forwarded_for,
                       const std::vector<Cidr>& trusted_proxies);

// ClientHost of a running call: its peer and x-forwarded-for metadata.
std::string ClientHost(const grpc::ServerContext& context,
                       const std::vector<Cidr>& trusted_proxies);

}  // namespace scanprep::server
