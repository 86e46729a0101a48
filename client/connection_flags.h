// SPDX-License-Identifier: Apache-2.0
// The flags that choose a command's transport security, shared by every command that connects:
// TLS when --tls_ca is given (plus a client certificate for mutual TLS), plaintext otherwise.
#pragma once

#include <memory>
#include <vector>

#include <grpcpp/security/credentials.h>

#include "absl/status/statusor.h"
#include "client/cli_args.h"

namespace scanprep::client {

// --server, for every command that connects: where the service is.
inline constexpr char kServerFlagHelp[] =
    "HOST:PORT of the service, a list IP:PORT,IP:PORT,… or a gRPC name such as "
    "dns:///NAME:PORT; calls are spread round-robin over its addresses, and a job whose "
    "call ends UNAVAILABLE (a replica died or drains) is sent again, at most 3 attempts within "
    "its deadline";

// Appends --tls_ca, --tls_cert and --tls_key to a command's flags.
void AddTlsFlags(std::vector<FlagSpec>& flags);

// The channel credentials --tls_ca, --tls_cert and --tls_key ask for.
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> CredentialsFromArgs(
    const ParsedArgs& args);

}  // namespace scanprep::client
