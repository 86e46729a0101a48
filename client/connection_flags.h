// SPDX-License-Identifier: Apache-2.0
// The flags of every command that connects (`info`, `process`, `health`, `load`): where the
// service is (--server) and the transport security, TLS when --tls_ca is given (plus a client
// certificate for mutual TLS), plaintext otherwise.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <grpcpp/security/credentials.h>

#include "absl/status/statusor.h"
#include "client/cli_args.h"

namespace scanprep::client {

inline constexpr char kServerFlag[] = "server";
// --server's value when the command gives it a default.
inline constexpr char kDefaultServer[] = "localhost:50051";

// --server's FlagSpec: with kDefaultServer as its default, or with none when `required`.
FlagSpec ServerFlag(bool required);

// The channel target --server names (kDefaultServer when absent): INVALID_ARGUMENT, a usage
// error, for a list that does not parse.
absl::StatusOr<std::string> TargetFromArgs(const ParsedArgs& args);

// Appends --tls_ca, --tls_cert and --tls_key to a command's flags.
void AddTlsFlags(std::vector<FlagSpec>& flags);

// The channel credentials --tls_ca, --tls_cert and --tls_key ask for.
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> CredentialsFromArgs(
    const ParsedArgs& args);

}  // namespace scanprep::client
