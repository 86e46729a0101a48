// Client library for the ScanPrep service, used by the `scanprep` CLI and the tests: streams a
// job (header, then chunks), relays progress, and returns the result cloud and the report.
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
#include "core/point_cloud.h"
#include "scanprep/v1/scanprep.grpc.pb.h"

namespace scanprep::client {

namespace v1 = ::scanprep::v1;

inline constexpr size_t kDefaultChunkPoints = 32'768;

// The call's transfer phases on the client's clock (the processing time is the server's
// report.processing_seconds).
struct TransferSeconds {
  // First point chunk written → the server's progress for the last point (the half-close when
  // the server sent none).
  double upload = 0;
  double download = 0;  // first result chunk received → the report received
};

struct ProcessResult {
  // In the job's unit and the common frame; `scans` carries the header's scan ids.
  PointCloud cloud;
  v1::Report report;
  TransferSeconds transfer;
};

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
  std::optional<absl::Duration> timeout;  // none = no deadline
  ProgressCallback progress;
  CallCanceller* canceller = nullptr;
  size_t chunk_points = kDefaultChunkPoints;
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
  // A channel to HOST:PORT; plaintext unless `credentials` say otherwise.
  static ScanPrepClient Connect(
      const std::string& target,
      std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials());

  absl::StatusOr<v1::Info> GetInfo(std::optional<absl::Duration> timeout = std::nullopt);

  // Runs one job. `points` are in the header's unit and in each scan's own frame; points.scan
  // indexes header.scans. header.total_points is filled in when zero. A failed call returns the
  // server's status code and message unchanged, with its error details (see call_error.h).
  absl::StatusOr<ProcessResult> Process(v1::JobHeader header, const PointCloud& points,
                                        const CallOptions& options = {});

 private:
  std::unique_ptr<v1::ScanPrep::Stub> stub_;
};

// A channel to `target` (HOST:PORT or a gRPC name such as dns:///name:port) that spreads its
// calls round-robin over every address the name resolves to, so one client loads all replicas
// behind a headless service instead of the first one it reaches.
std::shared_ptr<grpc::Channel> RoundRobinChannel(
    const std::string& target,
    std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials());

// The request chunk for points [begin, end); scan_index only when `with_scan_index`.
void RequestChunk(const PointCloud& points, size_t begin, size_t end, bool with_scan_index,
                  v1::PointChunk* out);
// Appends a result chunk to `cloud`; DATA_LOSS when its arrays disagree.
absl::Status AppendResultChunk(const v1::PointChunk& chunk, PointCloud& cloud);

}  // namespace scanprep::client
