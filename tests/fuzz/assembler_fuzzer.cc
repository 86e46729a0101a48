// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the server's JobAssembler fed a stream of ProcessRequest messages decoded from
// the input, then Finish(); a small assembled job also runs the whole default pipeline, whose
// output must keep finite coordinates and normals. Degenerate clouds (one point, duplicates,
// collinear points) reach the stages this way.
//
// Input: a sequence of pieces, each a 2-byte little-endian length followed by that many bytes of
// a serialized ProcessRequest; a piece that does not parse ends the stream. An end message whose
// crc32 is 0 gets the CRC-32 of the chunks before it, so that mutated points still reach the
// pipeline; any other crc32 is checked as sent.
#include <cstddef>
#include <cstdint>

#include <google/protobuf/stubs/logging.h>

#include "core/base/cancel.h"
#include "core/pipeline/pipeline.h"
#include "server/job/job_assembler.h"
#include "tests/fuzz/fuzz_checks.h"

namespace {

constexpr int kMaxMessages = 16;
constexpr size_t kMaxPipelinePoints = 2000;

}  // namespace

// protobuf logs every invalid UTF-8 string it parses; at thousands of inputs a second that is
// noise and slows the fuzzer down.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using scanprep::fuzz::Require;
  // Small limits so the limit checks are reachable with small inputs.
  scanprep::server::JobAssembler assembler(
      scanprep::server::JobLimits{.max_points_per_job = 4096, .max_chunk_points = 1024});
  scanprep::StreamChecksum sent;
  size_t pos = 0;
  for (int m = 0; m < kMaxMessages && pos + 2 <= size; ++m) {
    const size_t length = data[pos] | (static_cast<size_t>(data[pos + 1]) << 8);
    pos += 2;
    if (length > size - pos) break;
    scanprep::v1::ProcessRequest request;
    if (!request.ParseFromArray(data + pos, static_cast<int>(length))) break;
    pos += length;
    if (request.has_end() && request.end().crc32() == 0) {
      request.mutable_end()->set_crc32(sent.crc32());
    }
    if (!assembler.Add(request).ok()) return 0;  // the service ends the call here
    if (request.has_points()) sent.Add(request.points());
  }
  auto job = assembler.Finish();
  if (!job.ok()) return 0;
  scanprep::PointCloud& cloud = job->cloud;
  scanprep::fuzz::CheckCloud(cloud);
  Require(cloud.size() == job->points_received - job->points_invalid, "valid points are kept");
  if (cloud.size() > kMaxPipelinePoints) return 0;
  scanprep::CancelToken cancel;
  auto report = scanprep::RunPipeline(cloud, job->options, cancel);
  if (!report.ok()) return 0;  // a precise error is an acceptable answer
  scanprep::fuzz::CheckCloud(cloud);
  scanprep::fuzz::CheckNormals(cloud);
  return 0;
}
