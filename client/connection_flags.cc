// SPDX-License-Identifier: Apache-2.0
#include "client/connection_flags.h"

#include "client/scanprep_client.h"

namespace scanprep::client {

void AddTlsFlags(std::vector<FlagSpec>& flags) {
  flags.insert(
      flags.end(),
      {
          {"tls_ca", FlagSpec::kValue,
           "PEM CA that signed the server's certificate: connect with TLS (default: plaintext)"},
          {"tls_cert", FlagSpec::kValue, "PEM client certificate for mutual TLS (needs --tls_ca)"},
          {"tls_key", FlagSpec::kValue, "PEM private key of --tls_cert"},
      });
}

absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> CredentialsFromArgs(
    const ParsedArgs& args) {
  return ChannelCredentialsFor(
      {.ca = args.Get("tls_ca"), .cert = args.Get("tls_cert"), .key = args.Get("tls_key")});
}

}  // namespace scanprep::client
