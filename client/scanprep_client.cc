// SPDX-License-Identifier: Apache-2.0
#include "client/scanprep_client.h"

#include <regex>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/call_error.h"
#include "core/base/status_macros.h"
#include "core/io/read_file.h"

namespace scanprep::client {
namespace {

void SetDeadline(grpc::ClientContext& context, const std::optional<absl::Duration>& timeout) {
  if (timeout) context.set_deadline(absl::ToChronoTime(absl::Now() + *timeout));
}

// Before another attempt: long enough for the channel to see a dead replica's connection fail.
constexpr absl::Duration kRetryPause = absl::Milliseconds(100);

}  // namespace

void CallCanceller::Cancel() {
  std::lock_guard lock(mu_);
  cancelled_ = true;
  if (context_ != nullptr) context_->TryCancel();
}

bool CallCanceller::Attach(grpc::ClientContext* context) {
  std::lock_guard lock(mu_);
  context_ = context;
  return !cancelled_;
}

void CallCanceller::Detach() {
  std::lock_guard lock(mu_);
  context_ = nullptr;
}

ScanPrepClient::ScanPrepClient(std::shared_ptr<grpc::Channel> channel)
    : stub_(v1::ScanPrep::NewStub(std::move(channel))) {}

absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> ChannelCredentialsFor(
    const TlsFiles& files) {
  if (files.cert.empty() != files.key.empty()) {
    return absl::InvalidArgumentError("--tls_cert and --tls_key go together");
  }
  if (files.ca.empty()) {
    if (!files.cert.empty()) {
      return absl::InvalidArgumentError(
          "--tls_cert needs --tls_ca (the CA that signed the server's certificate)");
    }
    return grpc::InsecureChannelCredentials();
  }
  grpc::SslCredentialsOptions options;
  const std::pair<const std::string*, std::string*> pem[] = {
      {&files.ca, &options.pem_root_certs},
      {&files.cert, &options.pem_cert_chain},
      {&files.key, &options.pem_private_key}};
  for (const auto& [path, into] : pem) {
    if (path->empty()) continue;
    SCANPREP_ASSIGN_OR_RETURN(auto text, io::ReadFileToString(*path));
    *into = std::move(text);
  }
  return grpc::SslCredentials(options);
}

ScanPrepClient ScanPrepClient::Connect(const std::string& target,
                                       std::shared_ptr<grpc::ChannelCredentials> credentials) {
  return ScanPrepClient(RoundRobinChannel(target, std::move(credentials)));
}

std::shared_ptr<grpc::Channel> RoundRobinChannel(
    const std::string& target, std::shared_ptr<grpc::ChannelCredentials> credentials) {
  grpc::ChannelArguments arguments;
  arguments.SetLoadBalancingPolicyName("round_robin");
  return grpc::CreateCustomChannel(target, std::move(credentials), arguments);
}

absl::StatusOr<std::string> ChannelTarget(const std::string& servers) {
  if (servers.find(',') == std::string::npos || absl::StartsWith(servers, "ipv4:") ||
      absl::StartsWith(servers, "ipv6:")) {
    return servers;
  }
  static const std::regex kIpv4HostPort(R"(\d{1,3}(\.\d{1,3}){3}:\d{1,5})");
  for (absl::string_view server : absl::StrSplit(servers, ',')) {
    if (!std::regex_match(server.begin(), server.end(), kIpv4HostPort)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--server: '", std::string(server),
          "' in a list is not an IPv4 address:port; list "
          "addresses (10.0.0.1:50051,10.0.0.2:50051) or give one name (dns:///name:50051 "
          "spreads over every address of the name)"));
    }
  }
  return absl::StrCat("ipv4:", servers);
}

absl::StatusOr<v1::GetInfoResponse> ScanPrepClient::GetInfo(std::optional<absl::Duration> timeout) {
  grpc::ClientContext context;
  SetDeadline(context, timeout);
  v1::GetInfoResponse info;
  grpc::Status status = stub_->GetInfo(&context, v1::GetInfoRequest(), &info);
  if (!status.ok()) return FromGrpc(status);
  return info;
}

void RequestChunk(const PointCloud& points, size_t begin, size_t end, bool with_scan_index,
                  v1::PointChunk* out) {
  const size_t n = end - begin;
  out->mutable_xyz()->Reserve(3 * n);
  for (size_t i = begin; i < end; ++i) {
    out->add_xyz(points.x[i]);
    out->add_xyz(points.y[i]);
    out->add_xyz(points.z[i]);
  }
  auto copy = [&](const auto& from, auto* to) {
    if (!from.empty()) to->Add(from.begin() + begin, from.begin() + end);
  };
  if (with_scan_index) copy(points.scan, out->mutable_scan_index());
  copy(points.scanline, out->mutable_scanline());
  copy(points.quality, out->mutable_quality());
  copy(points.intensity, out->mutable_intensity());
}

absl::StatusOr<ProcessResult> ScanPrepClient::Process(v1::JobHeader header,
                                                      const PointCloud& points,
                                                      const CallOptions& options) {
  if (header.total_points() == 0) header.set_total_points(points.size());
  const absl::Time deadline =
      options.timeout ? absl::Now() + *options.timeout : absl::InfiniteFuture();
  for (int attempt = 1;; ++attempt) {
    absl::StatusOr<ProcessResult> result = ProcessOnce(header, points, options, deadline);
    if (result.ok()) result->retries = attempt - 1;
    if (result.ok() || result.status().code() != absl::StatusCode::kUnavailable ||
        attempt >= options.max_attempts || absl::Now() + kRetryPause >= deadline) {
      return result;
    }
    absl::SleepFor(kRetryPause);
  }
}

absl::StatusOr<ProcessResult> ScanPrepClient::ProcessOnce(const v1::JobHeader& job_header,
                                                          const PointCloud& points,
                                                          const CallOptions& options,
                                                          absl::Time deadline) {
  v1::JobHeader header = job_header;
  const size_t chunk_points = std::max<size_t>(1, options.chunk_points);
  const bool with_scan_index = header.scans_size() > 1;

  grpc::ClientContext context;
  if (deadline != absl::InfiniteFuture()) context.set_deadline(absl::ToChronoTime(deadline));
  if (options.canceller != nullptr && !options.canceller->Attach(&context)) {
    return absl::CancelledError("the call was cancelled before it started");
  }
  std::unique_ptr<grpc::ClientReaderWriter<v1::ProcessRequest, v1::ProcessResponse>> stream =
      stub_->Process(&context);

  // Responses are read on their own thread so progress flows while this thread uploads.
  ResultReceiver receiver(header);
  TransferSeconds transfer;
  // gRPC's Write returns once the transport took the message, which can be megabytes before the
  // server read it; the server's UPLOAD progress for the last point says it decoded them all.
  const uint64_t total_points = header.total_points();
  std::optional<absl::Time> upload_acked;
  std::thread reader([&] {
    v1::ProcessResponse response;
    std::optional<absl::Time> download_start;
    while (stream->Read(&response)) {
      switch (response.kind_case()) {
        case v1::ProcessResponse::kProgress:
          if (response.progress().phase() == v1::Progress::PHASE_UPLOAD &&
              response.progress().points() == total_points) {
            upload_acked = absl::Now();
          }
          if (options.progress) options.progress(response.progress());
          continue;
        case v1::ProcessResponse::kPoints:
          if (!download_start) download_start = absl::Now();
          break;
        case v1::ProcessResponse::kReport:
          // No points come back when every point was removed; that download took no time.
          if (download_start) {
            transfer.download = absl::ToDoubleSeconds(absl::Now() - *download_start);
          }
          break;
        default:
          break;
      }
      receiver.Add(response);
    }
  });

  v1::ProcessRequest request;
  *request.mutable_header() = std::move(header);
  // A failed write means the server already ended the call; Finish() tells why.
  bool writing = stream->Write(request);
  const absl::Time upload_start = absl::Now();
  StreamChecksum sent;
  for (size_t begin = 0; writing && begin < points.size(); begin += chunk_points) {
    request.Clear();
    RequestChunk(points, begin, std::min(points.size(), begin + chunk_points), with_scan_index,
                 request.mutable_points());
    sent.Add(request.points());
    writing = stream->Write(request);
  }
  if (writing) {
    *request.mutable_end() = sent.End();
    if (stream->Write(request)) stream->WritesDone();
  }
  const absl::Time half_closed = absl::Now();
  reader.join();
  transfer.upload = absl::ToDoubleSeconds(upload_acked.value_or(half_closed) - upload_start);
  grpc::Status status = stream->Finish();
  if (options.canceller != nullptr) options.canceller->Detach();

  if (!status.ok()) return FromGrpc(status);
  auto result = std::move(receiver).Finish();
  if (result.ok()) result->transfer = transfer;
  return result;
}

}  // namespace scanprep::client
