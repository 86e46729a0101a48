// SPDX-License-Identifier: Apache-2.0
// What a job call reads and writes, whichever RPC carries it: Process's bidirectional stream, or
// ProcessUnary's one request and one response seen as that stream, so that both run the same
// upload checks, admission, reservations, processing and download (scanprep_service.cc).
#pragma once

#include <cstdint>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"

#include "scanprep/v1/scanprep.grpc.pb.h"
#include "server/metrics/service_metrics.h"
#include "wire/stream_checksum.h"

namespace scanprep::server {

class JobStream {
 public:
  virtual ~JobStream() = default;
  // The next request message; false at the end of the upload (or when the client is gone).
  virtual bool Read(v1::ProcessRequest* request) = 0;
  // Sends (or keeps) one response message; false when the client is gone.
  virtual bool Write(const v1::ProcessResponse& response) = 0;
  // Bytes the call holds outside the job's own data (a unary request, read whole before its
  // header could be checked), for the job's memory reservation.
  virtual uint64_t held_bytes() const = 0;
  virtual const RpcMethod& method() const = 0;
  // Bytes of the answer still to be sent once the handler returns (a unary answer, which gRPC
  // sends then); 0 for a stream, whose responses are written before.
  virtual uint64_t unsent_bytes() const { return 0; }
  // What the call carries that is wrong before any of it is read (a unary request's crc32 that
  // its points do not have); OK for a stream, whose messages are checked as they arrive.
  virtual absl::Status Check() const { return absl::OkStatus(); }
};

// Process: the stream itself.
class BidiJobStream final : public JobStream {
 public:
  using Stream = grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>;
  explicit BidiJobStream(Stream* stream) : stream_(stream) {}
  bool Read(v1::ProcessRequest* request) override { return stream_->Read(request); }
  bool Write(const v1::ProcessResponse& response) override { return stream_->Write(response); }
  uint64_t held_bytes() const override { return 0; }
  const RpcMethod& method() const override { return kProcessRpc; }

 private:
  Stream* stream_;
};

// ProcessUnary: reads the header, the points in pieces of at most `chunk_points` (as a client
// would stream them) and a StreamEnd summed over those pieces; writes the result's chunks into
// one chunk of `response`, the report, and an end summed over that one chunk. Progress is not
// kept. The request's own crc32 is checked by Check, before this reads.
class UnaryJobStream final : public JobStream {
 public:
  UnaryJobStream(v1::ProcessUnaryRequest& request, v1::ProcessUnaryResponse& response,
                 uint64_t chunk_points);
  bool Read(v1::ProcessRequest* request) override;
  bool Write(const v1::ProcessResponse& response) override;
  uint64_t held_bytes() const override { return held_bytes_; }
  uint64_t unsent_bytes() const override { return response_.ByteSizeLong(); }
  const RpcMethod& method() const override { return kProcessUnaryRpc; }
  // DATA_LOSS (reason CHECKSUM_MISMATCH) when the request states a crc32 that its points do not
  // have.
  absl::Status Check() const override;

 private:
  v1::ProcessUnaryRequest& request_;
  v1::ProcessUnaryResponse& response_;
  const uint64_t chunk_points_;
  const uint64_t held_bytes_;
  const uint64_t points_;
  uint64_t next_point_ = 0;
  bool header_read_ = false;
  bool ended_ = false;
  bool unpacked_ = false;  // the request's points in the repeated form, to be sliced
  StreamChecksum upload_;
};

}  // namespace scanprep::server
