// SPDX-License-Identifier: Apache-2.0
#include "server/transport/transport_security.h"

#include <utility>

#include <grpcpp/security/tls_certificate_provider.h>
#include <grpcpp/security/tls_credentials_options.h>

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
  // Read once here, so that a missing or unreadable file fails at startup naming its flag.
  for (const auto& [path, flag] :
       {std::pair{flags.tls_cert, "tls_cert"}, std::pair{flags.tls_key, "tls_key"},
        std::pair{flags.tls_client_ca, "tls_client_ca"}}) {
    if (!path.empty()) SCANPREP_RETURN_IF_ERROR(ReadPemFile(path, flag).status());
  }
  if (!(flags.reload_interval >= absl::Seconds(1) && flags.reload_interval <= absl::Hours(24))) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tls_reload_interval=", absl::FormatDuration(flags.reload_interval),
                     ": the TLS files are read again every 1s to 24h"));
  }
  const auto seconds = static_cast<unsigned>(absl::ToInt64Seconds(flags.reload_interval));
  const bool mutual = !flags.tls_client_ca.empty();
  auto files = std::make_shared<grpc::experimental::FileWatcherCertificateProvider>(
      flags.tls_key, flags.tls_cert, flags.tls_client_ca, seconds);
  grpc::experimental::TlsServerCredentialsOptions options(files);
  options.watch_identity_key_cert_pairs();
  if (mutual) options.watch_root_certs();
  options.set_cert_request_type(mutual ? GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY
                                       : GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  return Transport{grpc::experimental::TlsServerCredentials(options),
                   mutual ? "mutual TLS (client certificates required and verified)" : "TLS"};
}

}  // namespace scanprep::server
