// SPDX-License-Identifier: Apache-2.0
#include "client/result_receiver.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "wire/chunk_arrays.h"

namespace scanprep::client {
namespace {

// A present optional array must have one value per point.
bool Fits(int size, size_t n) { return size == 0 || static_cast<size_t>(size) == n; }

template <class T, class Repeated>
void Append(const Repeated& from, std::vector<T>& to) {
  to.insert(to.end(), from.begin(), from.end());
}

}  // namespace

absl::Status AppendResultChunk(const v1::PointChunk& chunk, ProcessResult& result) {
  PointCloud& cloud = result.cloud;
  const size_t n = chunk.xyz_size() / 3;
  if (chunk.xyz_size() % 3 != 0 || !Fits(chunk.scan_index_size(), n) ||
      !Fits(chunk.scanline_size(), n) || !Fits(chunk.quality_size(), n) ||
      !Fits(chunk.intensity_size(), n) || !Fits(chunk.normal_size(), 3 * n) ||
      !Fits(chunk.source_index_size(), n) || chunk.flags().size() != n) {
    return absl::DataLossError("the server sent a result chunk whose arrays disagree in length");
  }
  for (size_t i = 0; i < n; ++i) {
    cloud.x.push_back(chunk.xyz(3 * i));
    cloud.y.push_back(chunk.xyz(3 * i + 1));
    cloud.z.push_back(chunk.xyz(3 * i + 2));
    if (chunk.normal_size() > 0) {
      cloud.nx.push_back(chunk.normal(3 * i));
      cloud.ny.push_back(chunk.normal(3 * i + 1));
      cloud.nz.push_back(chunk.normal(3 * i + 2));
    }
  }
  if (chunk.scan_index_size() > 0) {
    Append(chunk.scan_index(), cloud.scan);
  } else {
    cloud.scan.resize(cloud.scan.size() + n, 0);
  }
  Append(chunk.scanline(), cloud.scanline);
  Append(chunk.quality(), cloud.quality);
  Append(chunk.intensity(), cloud.intensity);
  cloud.flags.insert(cloud.flags.end(), chunk.flags().begin(), chunk.flags().end());
  Append(chunk.source_index(), result.source_index);
  return absl::OkStatus();
}

absl::Status GatherSentAttributes(const PointCloud& sent, ProcessResult& result) {
  if (sent.attributes.empty()) return absl::OkStatus();
  if (result.source_index.size() != result.cloud.size()) {
    return absl::DataLossError(
        absl::StrCat("the server sent source_index for ", result.source_index.size(), " of the ",
                     result.cloud.size(), " points returned: the attributes cannot be given back"));
  }
  for (uint32_t position : result.source_index) {
    if (position >= sent.size()) {
      return absl::DataLossError(absl::StrCat("the server sent source_index ", position,
                                              " for an upload of ", sent.size(), " points"));
    }
  }
  result.cloud.attributes = GatherAttributes(sent.attributes, result.source_index);
  return absl::OkStatus();
}

ResultReceiver::ResultReceiver(const v1::JobHeader& header) {
  // Result chunks are relative to the job's origin; the writers add it back in double.
  const v1::Vec3& origin = header.origin();
  result_.cloud.origin = Eigen::Vector3d(origin.x(), origin.y(), origin.z());
  for (const v1::ScanHeader& scan : header.scans()) {
    result_.cloud.scans.push_back({.id = scan.scan_id()});
  }
}

void ResultReceiver::Add(v1::ProcessResponse& response) {
  if (error_.ok()) error_ = AddMessage(response);
}

absl::Status ResultReceiver::AddMessage(v1::ProcessResponse& response) {
  if (has_end_) {
    return absl::DataLossError("the server sent a message after the result's end message");
  }
  switch (response.kind_case()) {
    case v1::ProcessResponse::kPoints: {
      received_.Add(response.points());
      std::string bad_array;
      if (!UnpackArrays(*response.mutable_points(), bad_array).ok()) {
        return absl::DataLossError(
            absl::StrCat("the server sent a result chunk whose ", bad_array, " is malformed"));
      }
      return AppendResultChunk(response.points(), result_);
    }
    case v1::ProcessResponse::kReport:
      result_.report = std::move(*response.mutable_report());
      has_report_ = true;
      return absl::OkStatus();
    case v1::ProcessResponse::kEnd:
      end_ = response.end();
      has_end_ = true;
      return absl::OkStatus();
    default:
      return absl::OkStatus();
  }
}

absl::StatusOr<ProcessResult> ResultReceiver::Finish() && {
  SCANPREP_RETURN_IF_ERROR(error_);
  if (!has_report_) return absl::DataLossError("the server ended the call without a report");
  if (!has_end_) {
    return absl::DataLossError(absl::StrCat("the result ended without its end message after ",
                                            received_.points(), " points: the stream was cut"));
  }
  if (end_.points() != received_.points() || end_.points() != result_.report.points_returned()) {
    return absl::DataLossError(
        absl::StrCat("the result's end message declares ", end_.points(), " points and the report ",
                     result_.report.points_returned(), ", but ", received_.points(), " arrived"));
  }
  if (end_.crc32() != received_.crc32()) {
    return absl::DataLossError(absl::StrFormat(
        "the result's end message has CRC-32 0x%08x but the %d points received have 0x%08x: "
        "the result was corrupted in transfer",
        end_.crc32(), received_.points(), received_.crc32()));
  }
  return std::move(result_);
}

}  // namespace scanprep::client
