// SPDX-License-Identifier: Apache-2.0
// Transport security of the real service: certificates made at test time by `openssl` (a CA, a
// server certificate for 127.0.0.1/localhost, a client certificate, and a second CA with its own
// client certificate); the server configured by the same code as the binary's --tls_* flags.
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "client/scanprep_client.h"
#include "server/transport/transport_security.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// The files under one directory: ca, server, client, other_ca, other_client, other_server (.pem
// and .key).
class Certificates {
 public:
  Certificates()
      : dir_(fs::path(::testing::TempDir()) / ("scanprep_tls_" + std::to_string(getpid()))) {
    fs::create_directories(dir_);
    std::ofstream(dir_ / "server.ext") << "basicConstraints=CA:FALSE\n"
                                          "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
    std::ofstream(dir_ / "client.ext") << "basicConstraints=CA:FALSE\n"
                                          "extendedKeyUsage=clientAuth\n";
    ok_ = MakeCa("ca") && MakeCa("other_ca") && MakeLeaf("server", "ca", "server.ext") &&
          MakeLeaf("client", "ca", "client.ext") &&
          MakeLeaf("other_client", "other_ca", "client.ext") &&
          MakeLeaf("other_server", "other_ca", "server.ext");
  }
  ~Certificates() { fs::remove_all(dir_); }

  bool ok() const { return ok_; }
  const std::string& log() const { return log_; }
  std::string pem(const std::string& name) const { return (dir_ / (name + ".pem")).string(); }
  std::string key(const std::string& name) const { return (dir_ / (name + ".key")).string(); }

 private:
  bool Run(const std::string& command) {
    const CommandResult r = RunCommand("cd " + dir_.string() + " && openssl " + command);
    log_ += r.output;
    return r.exit_code == 0;
  }
  // EC P-256 keys: quick to generate.
  static std::string NewKey(const std::string& name) {
    return "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout " + name + ".key";
  }
  bool MakeCa(const std::string& name) {
    return Run("req -x509 " + NewKey(name) + " -out " + name + ".pem -days 2 -subj /CN=" + name);
  }
  bool MakeLeaf(const std::string& name, const std::string& ca, const std::string& ext) {
    return Run("req " + NewKey(name) + " -out " + name + ".csr -subj /CN=" + name) &&
           Run("x509 -req -in " + name + ".csr -CA " + ca + ".pem -CAkey " + ca +
               ".key -CAcreateserial -days 2 -out " + name + ".pem -extfile " + ext);
  }

  fs::path dir_;
  std::string log_;
  bool ok_ = false;
};

server::ServerOptions Secured(std::shared_ptr<grpc::ServerCredentials> credentials) {
  server::ServerOptions options;
  options.credentials = std::move(credentials);
  return options;
}

std::shared_ptr<grpc::ChannelCredentials> Credentials(const client::TlsFiles& files) {
  auto credentials = client::ChannelCredentialsFor(files);
  EXPECT_TRUE(credentials.ok()) << credentials.status();
  return credentials.ok() ? *credentials : nullptr;
}

class MutualTls : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    certs_ = new Certificates();
    ASSERT_TRUE(certs_->ok()) << "openssl failed:\n" << certs_->log();
  }
  static void TearDownTestSuite() { delete certs_; }

  void SetUp() override {
    auto transport = server::TransportFromFlags({.tls_cert = certs_->pem("server"),
                                                 .tls_key = certs_->key("server"),
                                                 .tls_client_ca = certs_->pem("ca")});
    ASSERT_TRUE(transport.ok()) << transport.status();
    server_ = std::make_unique<InProcessServer>(Secured(transport->credentials));
  }

  absl::StatusCode InfoCode(std::shared_ptr<grpc::ChannelCredentials> credentials) {
    auto info = client::ScanPrepClient::Connect(server_->target(), std::move(credentials))
                    .GetInfo(absl::Seconds(10));
    return info.status().code();
  }

  static Certificates* certs_;
  std::unique_ptr<InProcessServer> server_;
};
Certificates* MutualTls::certs_ = nullptr;

TEST_F(MutualTls, AClientWithAValidCertificateIsServed) {
  auto client = client::ScanPrepClient::Connect(
      server_->target(),
      Credentials(
          {.ca = certs_->pem("ca"), .cert = certs_->pem("client"), .key = certs_->key("client")}));
  auto info = client.GetInfo(absl::Seconds(10));
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->limits().max_points_per_job(), 20'000'000u);

  v1::JobHeader header = SimpleHeader(0.5);
  header.mutable_options()->add_stages("outliers");
  const GeneratedScan scan = NoisyPlaneWithSpikes(40, 0.5f);
  auto result = client.Process(header, scan.cloud, {.timeout = absl::Seconds(30)});
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->report.points_received(), scan.cloud.size());
  EXPECT_LT(result->cloud.size(), scan.cloud.size());  // the spikes went
}

TEST_F(MutualTls, AClientWithoutACertificateIsRefused) {
  EXPECT_EQ(InfoCode(Credentials({.ca = certs_->pem("ca")})), absl::StatusCode::kUnavailable);
}

TEST_F(MutualTls, AClientCertificateFromAnotherCaIsRefused) {
  EXPECT_EQ(InfoCode(Credentials({.ca = certs_->pem("ca"),
                                  .cert = certs_->pem("other_client"),
                                  .key = certs_->key("other_client")})),
            absl::StatusCode::kUnavailable);
}

TEST_F(MutualTls, APlaintextClientIsRefused) {
  EXPECT_EQ(InfoCode(grpc::InsecureChannelCredentials()), absl::StatusCode::kUnavailable);
}

TEST_F(MutualTls, AClientThatDoesNotTrustTheServerCaRefusesTheServer) {
  EXPECT_EQ(InfoCode(Credentials({.ca = certs_->pem("other_ca"),
                                  .cert = certs_->pem("client"),
                                  .key = certs_->key("client")})),
            absl::StatusCode::kUnavailable);
}

TEST_F(MutualTls, TheCliConnectsWithTheTlsFlags) {
  const std::string cli = std::string(SCANPREP_CLI_BINARY) + " info --server " + server_->target();
  const std::string ca = " --tls_ca " + certs_->pem("ca");
  const CommandResult ok = RunCommand(cli + ca + " --tls_cert " + certs_->pem("client") +
                                      " --tls_key " + certs_->key("client"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("20000000 points per job"));

  // A refused handshake reaches the client as UNAVAILABLE, like an unreachable server: exit 3.
  const CommandResult no_cert = RunCommand(cli + ca);
  EXPECT_EQ(no_cert.exit_code, 3);
  EXPECT_THAT(no_cert.output, HasSubstr("UNAVAILABLE"));
  const CommandResult half = RunCommand(cli + ca + " --tls_cert " + certs_->pem("client"));
  EXPECT_EQ(half.exit_code, 2);  // flags that do not go together: a usage error
  EXPECT_THAT(half.output, HasSubstr("--tls_cert and --tls_key go together"));
  // Control: the flags go together but a file cannot be read: a local failure, not usage.
  const CommandResult missing = RunCommand(cli + " --tls_ca /nonexistent/ca.pem");
  EXPECT_EQ(missing.exit_code, 1) << missing.output;
  EXPECT_THAT(missing.output, HasSubstr("file not found: /nonexistent/ca.pem"));
}

TEST(ServerTls, WithoutAClientCaAnyTlsClientIsServed) {
  Certificates certs;
  ASSERT_TRUE(certs.ok()) << certs.log();
  auto transport =
      server::TransportFromFlags({.tls_cert = certs.pem("server"), .tls_key = certs.key("server")});
  ASSERT_TRUE(transport.ok()) << transport.status();
  EXPECT_EQ(transport->description, "TLS");
  InProcessServer server(Secured(transport->credentials));
  auto info = client::ScanPrepClient::Connect(server.target(), Credentials({.ca = certs.pem("ca")}))
                  .GetInfo(absl::Seconds(10));
  EXPECT_TRUE(info.ok()) << info.status();
  // Still no plaintext.
  EXPECT_EQ(
      client::ScanPrepClient::Connect(server.target()).GetInfo(absl::Seconds(10)).status().code(),
      absl::StatusCode::kUnavailable);
}

// A certificate that cert-manager renews was served only after a restart: the files are read again
// every --tls_reload_interval. The server's files are swapped (by rename, as a Secret's volume
// is) for a certificate of another CA: within seconds a client of that CA is served and one of the
// first CA is refused, as before the swap the other way round.
TEST(ServerTls, ARenewedCertificateIsServedWithoutARestart) {
  Certificates certs;
  ASSERT_TRUE(certs.ok()) << certs.log();
  const fs::path dir = fs::path(certs.pem("server")).parent_path();
  const auto install = [&](const std::string& name) {
    for (const char* ext : {".pem", ".key"}) {
      fs::copy_file(dir / (name + ext), dir / (std::string("next") + ext),
                    fs::copy_options::overwrite_existing);
      fs::rename(dir / (std::string("next") + ext), dir / (std::string("live") + ext));
    }
  };
  install("server");
  auto transport = server::TransportFromFlags({.tls_cert = (dir / "live.pem").string(),
                                               .tls_key = (dir / "live.key").string(),
                                               .reload_interval = absl::Seconds(1)});
  ASSERT_TRUE(transport.ok()) << transport.status();
  InProcessServer server(Secured(transport->credentials));
  const auto served = [&](const std::string& ca) {
    return client::ScanPrepClient::Connect(server.target(), Credentials({.ca = certs.pem(ca)}))
        .GetInfo(absl::Seconds(10))
        .ok();
  };
  EXPECT_TRUE(served("ca"));
  EXPECT_FALSE(served("other_ca"));
  install("other_server");
  bool renewed = false;
  for (int i = 0; i < 50 && !renewed; ++i) {
    absl::SleepFor(absl::Milliseconds(200));
    renewed = served("other_ca");
  }
  EXPECT_TRUE(renewed) << "the renewed certificate was not served within 10 s";
  EXPECT_FALSE(served("ca"));
  const auto never = server::TransportFromFlags({.tls_cert = certs.pem("server"),
                                                 .tls_key = certs.key("server"),
                                                 .reload_interval = absl::ZeroDuration()});
  EXPECT_EQ(never.status().message(),
            "--tls_reload_interval=0: the TLS files are read again every "
            "1s to 24h");
}

TEST(TransportFlags, PlaintextOnlyWhenAskedForAndContradictionsAreRefused) {
  auto none = server::TransportFromFlags({});
  EXPECT_EQ(none.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(none.status().message()), HasSubstr("or --plaintext"));

  auto plaintext = server::TransportFromFlags({.plaintext = true});
  ASSERT_TRUE(plaintext.ok());
  EXPECT_EQ(plaintext->description, "plaintext");

  auto both =
      server::TransportFromFlags({.tls_cert = "c.pem", .tls_key = "k.pem", .plaintext = true});
  EXPECT_THAT(std::string(both.status().message()), HasSubstr("--plaintext contradicts"));
  auto ca_only = server::TransportFromFlags({.tls_client_ca = "ca.pem"});
  EXPECT_THAT(std::string(ca_only.status().message()),
              HasSubstr("needs both --tls_cert and --tls_key"));
  auto missing = server::TransportFromFlags(
      {.tls_cert = "/nonexistent/c.pem", .tls_key = "/nonexistent/k.pem"});
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(missing.status().message()),
              HasSubstr("--tls_cert: file not found: /nonexistent/c.pem"));

  auto client_cert_without_ca = client::ChannelCredentialsFor({.cert = "c.pem", .key = "k.pem"});
  EXPECT_THAT(std::string(client_cert_without_ca.status().message()),
              HasSubstr("--tls_cert needs --tls_ca"));
}

}  // namespace
}  // namespace scanprep::testing
