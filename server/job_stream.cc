// SPDX-License-Identifier: Apache-2.0
#include "server/job_stream.h"

#include <string>

#include "absl/strings/str_format.h"
#include "wire/chunk_arrays.h"
#include "wire/error_details.h"

namespace scanprep::server {

UnaryJobStream::UnaryJobStream(v1::ProcessUnaryRequest& request, v1::ProcessUnaryResponse& response,
                               uint64_t chunk_points)
    : request_(request),
      response_(response),
      chunk_points_(chunk_points),
      held_bytes_(request.ByteSizeLong()),
      points_(ChunkPoints(request.points())) {}

bool UnaryJobStream::Read(v1::ProcessRequest* request) {
  request->Clear();
  if (!header_read_) {
    header_read_ = true;
    *request->mutable_header() = request_.header();
    return true;
  }
  if (next_point_ < points_) {
    std::string bad_array;
    // Arrays sent in both forms, or of a byte count no multiple of 4, go on whole, to be
    // refused by the chunk's checks as a stream's chunk would be.
    if (!unpacked_ && !UnpackArrays(*request_.mutable_points(), bad_array).ok()) {
      request->mutable_points()->Swap(request_.mutable_points());
      next_point_ = points_;
      return true;
    }
    unpacked_ = true;
    const uint64_t end = std::min(points_, next_point_ + chunk_points_);
    *request->mutable_points() = SliceChunk(request_.points(), next_point_, end);
    upload_.Add(request->points());
    next_point_ = end;
    return true;
  }
  if (ended_) return false;
  ended_ = true;
  request_.clear_points();  // every piece is in the job now
  *request->mutable_end() = upload_.End();
  return true;
}

bool UnaryJobStream::Write(const v1::ProcessResponse& response) {
  if (response.has_points()) {
    AppendChunk(response.points(), *response_.mutable_points());
  } else if (response.has_report()) {
    *response_.mutable_report() = response.report();
  } else if (response.has_end()) {
    StreamChecksum sent;
    sent.Add(response_.points());
    *response_.mutable_end() = sent.End();
  }
  return true;
}

absl::Status UnaryJobStream::Check() const {
  if (!request_.has_crc32()) return absl::OkStatus();
  StreamChecksum received;
  received.Add(request_.points());
  if (received.crc32() == request_.crc32()) return absl::OkStatus();
  // Corrupted on the way, as a stream's end can find: the same request can succeed again.
  return WithReason(absl::DataLossError(absl::StrFormat(
                        "crc32 = 0x%08x but the %d points received have CRC-32 0x%08x: the "
                        "request was corrupted in transfer",
                        request_.crc32(), received.points(), received.crc32())),
                    "CHECKSUM_MISMATCH", absl::ZeroDuration());
}

}  // namespace scanprep::server
