// SPDX-License-Identifier: Apache-2.0
#include "client/connection_flags.h"

#include "absl/strings/str_cat.h"
#include "client/scanprep_client.h"

namespace scanprep::client {
namespace {

constexpr char kTlsCa[] = "tls_ca";
constexpr char kTlsCert[] = "tls_cert";
constexpr char kTlsKey[] = "tls_key";

}  // namespace

FlagSpec ServerFlag(bool required) {
  const std::string help =
      "HOST:PORT of the service, a list IP:PORT,IP:PORT,… or a gRPC name such as "
      "dns:///NAME:PORT; calls are spread round-robin over its addresses, and a job whose "
      "call ends UNAVAILABLE (a replica died or drains) is sent again, at most 3 attempts within "
      "its deadline";
  return {kServerFlag, FlagSpec::kValue,
          required ? help : absl::StrCat(help, " (default ", kDefaultServer, ")")};
}

absl::StatusOr<std::string> TargetFromArgs(const ParsedArgs& args) {
  return ChannelTarget(args.Get(kServerFlag, kDefaultServer));
}

void AddTlsFlags(std::vector<FlagSpec>& flags) {
  flags.insert(
      flags.end(),
      {
          {kTlsCa, FlagSpec::kValue,
           "PEM CA that signed the server's certificate: connect with TLS (default: plaintext)"},
          {kTlsCert, FlagSpec::kValue, "PEM client certificate for mutual TLS (needs --tls_ca)"},
          {kTlsKey, FlagSpec::kValue, "PEM private key of --tls_cert"},
      });
}

absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> CredentialsFromArgs(
    const ParsedArgs& args) {
  return ChannelCredentialsFor(
      {.ca = args.Get(kTlsCa), .cert = args.Get(kTlsCert), .key = args.Get(kTlsKey)});
}

}  // namespace scanprep::client
