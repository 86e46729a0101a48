// SPDX-License-Identifier: Apache-2.0
#include "server/transport/transport_security.h"

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/read_file.h"

namespace scanprep::server {
namespace {

absl::StatusOr<std::string> ReadPemFile(const std::string& path, const std::string& flag) {
  auto text = io::ReadFileToString(path);
  if (!text.ok()) {
    return absl::Status(text.status().code(),
                        absl::StrCat("--", flag, ": ", text.status().message()));
  }
  return text;
}

}  // namespace

absl::StatusOr<Transport> TransportFromFlags(const TransportFlags& flags) {
  const bool any_tls =
      !flags.tls_cert.empty() || !flags.tls_key.empty() || !flags.tls_client_ca.empty();
  if (flags.plaintext) {
    if (any_tls) {
      return absl::InvalidArgumentError(
          "--plaintext contradicts --tls_cert/--tls_key/--tls_client_ca; give one or the other");
    }
    return Transport{grpc::InsecureServerCredentials(), "plaintext"};
  }
  if (!any_tls) {
    return absl::InvalidArgumentError(
        "no transport security configured: give --tls_cert and --tls_key (and --tls_client_ca "
        "for mutual TLS), or --plaintext to serve unencrypted and unauthenticated on purpose");
  }
  if (flags.tls_cert.empty() || flags.tls_key.empty()) {
    return absl::InvalidArgumentError(
        "TLS needs both --tls_cert and --tls_key (--tls_client_ca alone is not enough)");
  }
  grpc::SslServerCredentialsOptions::PemKeyCertPair pair;
  SCANPREP_ASSIGN_OR_RETURN(pair.cert_chain, ReadPemFile(flags.tls_cert, "tls_cert"));
  SCANPREP_ASSIGN_OR_RETURN(pair.private_key, ReadPemFile(flags.tls_key, "tls_key"));

  grpc::SslServerCredentialsOptions options;
  options.pem_key_cert_pairs.push_back(std::move(pair));
  if (flags.tls_client_ca.empty()) {
    options.client_certificate_request = GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE;
    return Transport{grpc::SslServerCredentials(options), "TLS"};
  }
  SCANPREP_ASSIGN_OR_RETURN(options.pem_root_certs,
                            ReadPemFile(flags.tls_client_ca, "tls_client_ca"));
  options.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  return Transport{grpc::SslServerCredentials(options),
                   "mutual TLS (client certificates required and verified)"};
}

}  // namespace scanprep::server
