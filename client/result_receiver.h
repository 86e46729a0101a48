// SPDX-License-Identifier: Apache-2.0
// Collects a Process call's result messages (points, the report, the end message) and checks the
// end message's count and CRC-32 against the points that arrived, so that a cut or corrupted
// result is refused instead of written.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "scanprep/v1/scanprep.pb.h"
#include "wire/stream_checksum.h"

namespace scanprep::client {

namespace v1 = ::scanprep::v1;

// The call's transfer phases on the client's clock (the processing time is the server's
// report.processing_seconds).
struct TransferSeconds {
  // First point chunk written → the server's progress for the last point (the half-close when
  // the server sent none).
  double upload = 0;
  double download = 0;  // first result chunk received → the report received
};

struct ProcessResult {
  // In the job's unit and the common frame, relative to cloud.origin (the header's origin);
  // `scans` carries the header's scan ids.
  PointCloud cloud;
  // With JobHeader.return_source_index: each returned point's position in the upload.
  std::vector<uint32_t> source_index;
  v1::Report report;
  TransferSeconds transfer;
  int retries = 0;  // attempts that ended UNAVAILABLE before this one succeeded
};

class ResultReceiver {
 public:
  // The header's scan ids name the result's scans.
  explicit ResultReceiver(const v1::JobHeader& header);

  // A result message in stream order (progress messages are the caller's). After the first
  // error, later messages are ignored and Finish returns that error.
  void Add(v1::ProcessResponse& response);

  // The result once the server ended the call with OK; DATA_LOSS when the report or the end
  // message is missing or the end message's count or CRC-32 differs from the points received.
  absl::StatusOr<ProcessResult> Finish() &&;

 private:
  absl::Status AddMessage(v1::ProcessResponse& response);

  ProcessResult result_;
  StreamChecksum received_;
  bool has_report_ = false;
  bool has_end_ = false;
  v1::StreamEnd end_;
  absl::Status error_;
};

// Appends a result chunk to `result`'s cloud and source_index; DATA_LOSS when its arrays
// disagree.
absl::Status AppendResultChunk(const v1::PointChunk& chunk, ProcessResult& result);

// The attributes of `sent` (the uploaded points) for the result's points, by their source_index;
// DATA_LOSS when the server sent no source_index for some point or one beyond the upload.
absl::Status GatherSentAttributes(const PointCloud& sent, ProcessResult& result);

}  // namespace scanprep::client
