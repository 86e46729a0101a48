// SPDX-License-Identifier: Apache-2.0
// Shared by the service tests: the real service started in-process on an ephemeral loopback
// port, a raw-stream call for protocol tests, and a generated scan (noisy plane with spikes).
#pragma once

#include <algorithm>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "client/scanprep_client.h"
#include "core/base/point_cloud.h"
#include "server/scanprep_server.h"
#include "wire/chunk_arrays.h"
#include "wire/stream_checksum.h"

namespace scanprep::testing {

namespace v1 = ::scanprep::v1;

class InProcessServer {
 public:
  explicit InProcessServer(server::ServerOptions options = {}) {
    options.listen = "127.0.0.1:0";
    if (options.threads == 0) options.threads = 2;
    auto started = server::ScanPrepServer::Start(options);
    EXPECT_TRUE(started.ok()) << started.status();
    server_ = std::move(*started);
    target_ = absl::StrCat("127.0.0.1:", server_->port());
  }
  const std::string& target() const { return target_; }
  server::ScanPrepServer& server() { return *server_; }
  client::ScanPrepClient Client() const { return client::ScanPrepClient::Connect(target_); }
  std::unique_ptr<v1::ScanPrep::Stub> Stub() const {
    return v1::ScanPrep::NewStub(grpc::CreateChannel(target_, grpc::InsecureChannelCredentials()));
  }

 private:
  std::unique_ptr<server::ScanPrepServer> server_;
  std::string target_;
};

// Whether RawCall ends an upload that starts with a header the way the client library does.
enum class Upload {
  kEnded,  // a StreamEnd with the chunks' count and CRC-32 appended, unless the requests have one
  kCut,    // the requests as they are: the half-close comes without an end message
};

// The end message for `requests`: the count and CRC-32 of their chunks.
inline v1::ProcessRequest EndRequest(const std::vector<v1::ProcessRequest>& requests) {
  StreamChecksum checksum;
  for (const v1::ProcessRequest& r : requests) {
    if (r.has_points()) checksum.Add(r.points());
  }
  v1::ProcessRequest end;
  *end.mutable_end() = checksum.End();
  return end;
}

// Writes `requests` (stopping when the server ended the call), half-closes, reads every
// response and returns the call's status. Like the client library, it declares a first header's
// total_points, when zero, as the points the requests carry, and (with Upload::kEnded) ends the
// upload with its end message.
inline grpc::Status RawCall(v1::ScanPrep::Stub& stub, std::vector<v1::ProcessRequest> requests,
                            std::vector<v1::ProcessResponse>* responses = nullptr,
                            Upload upload = Upload::kEnded) {
  if (!requests.empty() && requests[0].has_header()) {
    if (requests[0].header().total_points() == 0) {
      uint64_t points = 0;
      for (const v1::ProcessRequest& r : requests) points += r.points().xyz_size() / 3;
      requests[0].mutable_header()->set_total_points(points);
    }
    const bool has_end = std::any_of(requests.begin(), requests.end(),
                                     [](const v1::ProcessRequest& r) { return r.has_end(); });
    if (upload == Upload::kEnded && !has_end) requests.push_back(EndRequest(requests));
  }
  grpc::ClientContext context;
  auto stream = stub.Process(&context);
  bool open = true;
  for (const v1::ProcessRequest& r : requests) {
    if (!(open = stream->Write(r))) break;
  }
  if (open) stream->WritesDone();
  v1::ProcessResponse response;
  while (stream->Read(&response)) {
    if (responses != nullptr) responses->push_back(response);
  }
  return stream->Finish();
}

inline v1::ProcessRequest HeaderRequest(const v1::JobHeader& header) {
  v1::ProcessRequest r;
  *r.mutable_header() = header;
  return r;
}

// The header with the number of points the upload will send declared.
inline v1::ProcessRequest HeaderRequest(v1::JobHeader header, uint64_t total_points) {
  header.set_total_points(total_points);
  return HeaderRequest(header);
}

// `header` followed by `cloud` in chunks of `chunk_points` (single-scan: no scan_index).
inline std::vector<v1::ProcessRequest> JobRequests(const v1::JobHeader& header,
                                                   const PointCloud& cloud, size_t chunk_points) {
  std::vector<v1::ProcessRequest> requests(1);
  *requests[0].mutable_header() = header;
  for (size_t begin = 0; begin < cloud.size(); begin += chunk_points) {
    v1::ProcessRequest& r = requests.emplace_back();
    client::RequestChunk(cloud, begin, std::min(cloud.size(), begin + chunk_points), false,
                         r.mutable_points());
  }
  return requests;
}

inline v1::ProcessRequest ChunkRequest(const v1::PointChunk& chunk) {
  v1::ProcessRequest r;
  *r.mutable_points() = chunk;
  return r;
}

// A one-scan header in millimetres.
inline v1::JobHeader SimpleHeader(double scanline_spacing = 0.5) {
  v1::JobHeader header;
  header.set_job_id("test");
  header.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  v1::ScanHeader* scan = header.add_scans();
  scan->set_scan_id("plane");
  scan->set_scanline_spacing(scanline_spacing);
  return header;
}

// A chunk of `n` points on a line, spaced 0.5 mm.
inline v1::PointChunk LineChunk(size_t n) {
  v1::PointChunk chunk;
  for (size_t i = 0; i < n; ++i) {
    chunk.add_xyz(0.5f * i);
    chunk.add_xyz(0.f);
    chunk.add_xyz(0.f);
  }
  return chunk;
}

// A call that holds a ticket (admission.h: one of max_concurrent_jobs + max_queued_jobs) and a
// per-host place, uploading, until it is destroyed.
class HeldCall {
 public:
  explicit HeldCall(v1::ScanPrep::Stub& stub) : stream_(stub.Process(&context_)) {
    EXPECT_TRUE(stream_->Write(HeaderRequest(SimpleHeader(), 100)));
    EXPECT_TRUE(stream_->Write(ChunkRequest(LineChunk(100))));
    v1::ProcessResponse ack;
    EXPECT_TRUE(stream_->Read(&ack));
  }
  ~HeldCall() {
    context_.TryCancel();
    stream_->Finish();
  }

 private:
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ProcessRequest, v1::ProcessResponse>> stream_;
};

struct GeneratedScan {
  PointCloud cloud;         // one scan, millimetres, scanlines = grid rows
  std::vector<bool> spike;  // ground truth per point
};

// side×side grid at `spacing` mm with Gaussian noise (σ = spacing/20) in z; after about 1 % of
// the grid points a spike 5–20 spacings above it, in the same scanline so line order holds.
inline GeneratedScan NoisyPlaneWithSpikes(int side, float spacing, uint32_t seed = 11) {
  GeneratedScan g;
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, spacing / 20);
  std::uniform_real_distribution<float> height(5 * spacing, 20 * spacing), unit(0.f, 1.f);
  PointCloud& c = g.cloud;
  auto add = [&](float x, float y, float z, uint32_t row, bool spike) {
    c.x.push_back(x);
    c.y.push_back(y);
    c.z.push_back(z);
    c.scanline.push_back(row);
    g.spike.push_back(spike);
  };
  for (int row = 0; row < side; ++row) {
    for (int col = 0; col < side; ++col) {
      add(col * spacing, row * spacing, noise(rng), row, false);
      if (unit(rng) < 0.01f) add(col * spacing, row * spacing, height(rng), row, true);
    }
  }
  c.scans.push_back(ScanMeta{.id = "plane"});
  c.FinishLoading();
  return g;
}

// The plane with spikes as one unary request: xyz and scanline, packed.
inline v1::ProcessUnaryRequest UnaryRequest(const GeneratedScan& scan) {
  v1::ProcessUnaryRequest request;
  *request.mutable_header() = SimpleHeader();
  request.mutable_header()->set_total_points(scan.cloud.size());
  request.mutable_header()->set_result_arrays(v1::ARRAY_ENCODING_PACKED);
  v1::PointChunk& points = *request.mutable_points();
  for (size_t i = 0; i < scan.cloud.size(); ++i) {
    points.add_xyz(scan.cloud.x[i]);
    points.add_xyz(scan.cloud.y[i]);
    points.add_xyz(scan.cloud.z[i]);
    points.add_scanline(scan.cloud.scanline[i]);
  }
  PackArrays(points);
  return request;
}

}  // namespace scanprep::testing
