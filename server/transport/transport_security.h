// SPDX-License-Identifier: Apache-2.0
// The gRPC port's transport security from the server's flags: TLS, mutual TLS (client
// certificates required and verified against a CA), or plaintext when asked for explicitly.
#pragma once

#include <memory>
#include <string>

#include <grpcpp/security/server_credentials.h>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace scanprep::server {

struct TransportFlags {
  std::string tls_cert;       // PEM certificate chain of the server
  std::string tls_key;        // PEM private key of tls_cert
  std::string tls_client_ca;  // PEM CA bundle; set = clients must present a certificate it signed
  bool plaintext = false;     // serve without TLS; must be asked for, never a fallback
  // How often the three files are read again, so that a renewed certificate (cert-manager
  // rewrites its Secret's files) is served without a restart; gRPC reads at most once a second.
  absl::Duration reload_interval = absl::Minutes(1);
};

struct Transport {
  std::shared_ptr<grpc::ServerCredentials> credentials;
  std::string description;  // for the startup log line, e.g. "mutual TLS"
};

// The credentials the flags ask for. INVALID_ARGUMENT naming the flag when they contradict each
// other (--plaintext with a TLS flag, a certificate without its key, a client CA without a server
// certificate) or when none is given; the file reader's status, naming the flag, when a file
// cannot be read. TLS credentials read the files again every reload_interval (gRPC's
// FileWatcherCertificateProvider): new connections get the renewed certificate, and a file that
// cannot be read then keeps the last good one.
absl::StatusOr<Transport> TransportFromFlags(const TransportFlags& flags);

}  // namespace scanprep::server
