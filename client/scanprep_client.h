// SPDX-License-Identifier: Apache-2.0
// Client library for the ScanPrep service, used by the `scanprep` CLI and the tests: streams a
// job (header, chunks, end message), relays progress, and returns the result cloud and the report
// once the result's end message confirmed them.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/result_receiver.h"
#include "core/base/point_cloud.h"
#include "scanprep/v1/scanprep.grpc.pb.h"

namespace scanprep::client {

namespace v1 = ::scanprep::v1;

inline constexpr size_t kDefaultChunkPoints = 32'768;

// Called on the call's reader thread for every Progress event.
using ProgressCallback = std::function<void(const v1::Progress&)>;

// Lets another thread cancel a running call; the call then returns CANCELLED.
class CallCanceller {
 public:
  void Cancel();

 private:
  friend class ScanPrepClient;
  // Returns false when Cancel() came first.
  bool Attach(grpc::ClientContext* context);
  void Detach();

  std::mutex mu_;
  grpc::ClientContext* context_ = nullptr;
  bool cancelled_ = false;
};

struct CallOptions {
  std::optional<absl::Duration> timeout;  // none = no deadline; covers every attempt
  ProgressCallback progress;
  CallCanceller* canceller = nullptr;
  size_t chunk_points = kDefaultChunkPoints;
  // Attempts at a job whose call ends UNAVAILABLE (a replica that died or drains, a lost
  // connection): the service keeps nothing between calls, so the whole job is sent again, to the
  // next replica of a round-robin channel, while the deadline allows. 1 = no retry.
  int max_attempts = 3;
};

// PEM files for a TLS channel. With `ca` the server's certificate is verified against it; with
// `cert` and `key` the client presents its own certificate (mutual TLS).
struct TlsFiles {
  std::string ca;
  std::string cert;
  std::string key;
};

// TLS credentials when `files.ca` is set, else insecure ones (plaintext). INVALID_ARGUMENT when a
// certificate comes without its key (or the other way round) or without a CA; the file reader's
// status when a file cannot be read.
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> ChannelCredentialsFor(
    const TlsFiles& files);

class ScanPrepClient {
 public:
  explicit ScanPrepClient(std::shared_ptr<grpc::Channel> channel);
  // A RoundRobinChannel to `target`; plaintext unless `credentials` say otherwise.
  static ScanPrepClient Connect(
      const std::string& target,
      std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials());

  absl::StatusOr<v1::GetInfoResponse> GetInfo(std::optional<absl::Duration> timeout = std::nullopt);

  // Runs one job. `points` are in the header's unit and in each scan's own frame; points.scan
  // indexes header.scans. header.total_points is filled in when zero. A failed call returns the
  // server's status code and message unchanged, with its error details (see call_error.h); a
  // result whose end message does not match its points is DATA_LOSS (see ResultReceiver).
  absl::StatusOr<ProcessResult> Process(v1::JobHeader header, const PointCloud& points,
                                        const CallOptions& options = {});

 private:
  // One attempt, ending by `deadline`.
  absl::StatusOr<ProcessResult> ProcessOnce(const v1::JobHeader& header, const PointCloud& points,
                                            const CallOptions& options, absl::Time deadline);

  std::unique_ptr<v1::ScanPrep::Stub> stub_;
};

// A channel to `target` (HOST:PORT, a gRPC name such as dns:///name:port, or a list such as
// ipv4:10.0.0.1:50051,10.0.0.2:50051) that spreads its calls round-robin over every address the
// name resolves to, so one client loads all replicas behind a headless service instead of the
// first one it reaches.
std::shared_ptr<grpc::Channel> RoundRobinChannel(
    const std::string& target,
    std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials());

// The gRPC target for a --server value: HOST:PORT or any gRPC name as it is; a comma-separated
// list of IPv4 HOST:PORT literals as gRPC's "ipv4:" list. INVALID_ARGUMENT for a list with a name
// in it (a dns:/// name already round-robins over all its addresses).
absl::StatusOr<std::string> ChannelTarget(const std::string& servers);

// The request chunk for points [begin, end); scan_index only when `with_scan_index`.
void RequestChunk(const PointCloud& points, size_t begin, size_t end, bool with_scan_index,
                  v1::PointChunk* out);

}  // namespace scanprep::client
