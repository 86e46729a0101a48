// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the real gRPC service (in-process server on loopback, its default limits)
// fed sequences of ProcessRequest messages decoded from the input with FuzzedDataProvider:
// headers whose fields come from edge values (limits ± 1, 0, NaN, ±Inf, 1e300), parameter
// overrides drawn from a dictionary of the real stage and parameter names and of values at and
// beyond each parameter's range, scans up to the limit and one beyond it, point chunks (at most
// 5 x 128 points per call, to keep an input cheap), arbitrary bytes and truncated messages, and
// an end message (mostly right; now and then missing, miscounted or with a wrong CRC-32).
// Each call's status must obey the service's contract:
//   - OK only when the report counts exactly the declared points, which are all the points sent
//     before any message that failed to parse, the upload's end message arrived, the result
//     chunks hold the points returned and the result's end message matches them;
//   - every error carries a google.rpc.ErrorInfo reason (parsed by the client's own code), and an
//     INVALID_ARGUMENT exactly one field violation;
//   - nothing but INVALID_ARGUMENT, RESOURCE_EXHAUSTED (a limit), DATA_LOSS (a wrong CRC-32) and
//     OK (no INTERNAL, no hang:
//     each call has a deadline, libFuzzer's -timeout catches the rest, ASan any leak).
// Every choice's default (what an exhausted input decodes to: 0, false) is the valid one, so
// that short inputs reach the pipeline: one header, one chunk of 128 points on a wavy plane.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/grpcpp.h>

#include "absl/strings/str_cat.h"
#include "client/call_error.h"
#include "core/stages/params.h"
#include "core/stages/stage.h"
#include "scanprep/v1/scanprep.grpc.pb.h"
#include "server/scanprep_server.h"
#include "tests/fuzz/fuzz_checks.h"
#include "wire/chunk_arrays.h"
#include "wire/stream_checksum.h"

namespace {

namespace v1 = ::scanprep::v1;
using scanprep::fuzz::Require;

// Per-input cost (about 25 ms under ASan): two calls of a header and up to 5 chunks.
constexpr int kMaxCalls = 2;
constexpr int kMaxMessages = 6;
constexpr size_t kMaxChunkPoints = 128;

constexpr double kInf = std::numeric_limits<double>::infinity();
// Around the metadata limits (lengths within [1e-6, 1e4] mm, coordinates within 1e9 mm).
constexpr double kEdgeDoubles[] = {0,
                                   -0.0,
                                   1e-300,
                                   1e-7,
                                   1e-6,
                                   1e-3,
                                   0.5,
                                   1,
                                   2,
                                   1e4,
                                   1.0001e4,
                                   1e9,
                                   1.1e9,
                                   1e200,
                                   1e300,
                                   -1,
                                   -1e9,
                                   kInf,
                                   -kInf,
                                   std::numeric_limits<double>::quiet_NaN(),
                                   std::numeric_limits<double>::max(),
                                   std::numeric_limits<double>::denorm_min()};

struct Dictionary {
  std::vector<std::string> stages;  // real stage names, then invalid ones
  std::vector<std::string> params;  // real parameter names, then invalid ones
  // Per real parameter: its default, the ends of its range and just beyond, its choices.
  std::vector<std::vector<std::string>> values;
};

struct Service {
  std::unique_ptr<scanprep::server::ScanPrepServer> server;
  std::shared_ptr<grpc::Channel> channel;
  Dictionary dictionary;
  uint64_t max_points_per_job = 0;
  uint32_t max_scans_per_job = 0;
};

// Started once and kept for the whole run (libFuzzer exits without destroying it).
Service* service = nullptr;

Dictionary MakeDictionary() {
  Dictionary d;
  for (const scanprep::StageInfo& stage : scanprep::StageRegistry()) d.stages.push_back(stage.name);
  d.stages.insert(d.stages.end(), {"sharpen", "", std::string(300, 's')});
  for (const scanprep::ParamSpec& spec : scanprep::AllParamSpecs()) {
    d.params.push_back(spec.name);
    std::vector<std::string> values = {spec.default_text};
    if (spec.kind == scanprep::ParamKind::kChoice) {
      values.insert(values.end(), spec.choices.begin(), spec.choices.end());
    } else {
      for (const double end : {spec.range.min, spec.range.max}) {
        values.push_back(scanprep::FormatNumber(end));
        values.push_back(scanprep::FormatNumber(std::nextafter(end, -kInf)));
        values.push_back(scanprep::FormatNumber(std::nextafter(end, kInf)));
      }
    }
    d.values.push_back(std::move(values));
  }
  d.params.insert(d.params.end(), {"outliers.sigma", "", "smoothing."});
  return d;
}

const std::string& Pick(FuzzedDataProvider& in, const std::vector<std::string>& from) {
  return from[in.ConsumeIntegralInRange<size_t>(0, from.size() - 1)];
}

double Number(FuzzedDataProvider& in) {
  return in.ConsumeBool() ? in.PickValueInArray(kEdgeDoubles) : in.ConsumeFloatingPoint<double>();
}

// As a float; beyond its range an infinity (the cast itself would be undefined).
float ToFloat(double v) {
  if (std::abs(v) > std::numeric_limits<float>::max()) {
    return static_cast<float>(std::copysign(kInf, v));
  }
  return static_cast<float>(v);
}

void SetVec3(FuzzedDataProvider& in, v1::Vec3* v) {
  v->set_x(Number(in));
  v->set_y(Number(in));
  v->set_z(Number(in));
}

// A short string, sometimes not UTF-8 (protobuf refuses to parse it on the server).
std::string Text(FuzzedDataProvider& in) { return in.ConsumeRandomLengthString(16); }

// A parameter value: from the parameter's own edge values, a generic bad one, or the fuzzer's.
std::string ParamValue(FuzzedDataProvider& in, size_t param) {
  switch (in.ConsumeIntegralInRange(0, 3)) {
    case 0:
      if (param < service->dictionary.values.size()) {
        return Pick(in, service->dictionary.values[param]);
      }
      [[fallthrough]];
    case 1:
      return in.PickValueInArray(
          {"nan", "inf", "-1", "0", "1e30", "4294967297", "2.5", "bogus", ""});
    case 2:
      return std::string(257, '1');
    default:
      return Text(in);
  }
}

void FillScan(FuzzedDataProvider& in, int index, v1::ScanHeader* scan) {
  if (in.ConsumeBool()) scan->set_scan_id(absl::StrCat("scan", index));
  scan->set_scanline_spacing(in.ConsumeBool() ? Number(in) : 0.5);
  if (in.ConsumeBool()) scan->set_uncertainty(Number(in));
  if (in.ConsumeBool()) scan->set_point_spacing(Number(in));
  if (in.ConsumeBool()) SetVec3(in, scan->mutable_camera_position());
  if (in.ConsumeBool()) SetVec3(in, scan->mutable_view_direction());
  if (in.ConsumeBool()) SetVec3(in, scan->mutable_projector_position());
  if (in.ConsumeBool()) SetVec3(in, scan->mutable_projector_direction());
  if (in.ConsumeBool()) {
    v1::RigidTransform* t = scan->mutable_to_common();
    if (in.ConsumeBool()) {
      v1::Quaternion* q = t->mutable_rotation();
      q->set_w(in.ConsumeBool() ? Number(in) : 1);
      q->set_x(in.ConsumeBool() ? Number(in) : 0);
      q->set_y(in.ConsumeBool() ? Number(in) : 0);
      q->set_z(in.ConsumeBool() ? Number(in) : 0);
    }
    if (in.ConsumeBool()) SetVec3(in, t->mutable_translation());
  }
}

v1::JobHeader Header(FuzzedDataProvider& in, uint64_t points_to_send) {
  const Dictionary& d = service->dictionary;
  v1::JobHeader h;
  if (in.ConsumeBool()) h.set_job_id(in.ConsumeBool() ? "fuzz" : Text(in));
  h.set_unit(in.PickValueInArray({v1::LENGTH_UNIT_MILLIMETRE, v1::LENGTH_UNIT_METRE,
                                  v1::LENGTH_UNIT_MICROMETRE, v1::LENGTH_UNIT_INCH,
                                  v1::LENGTH_UNIT_UNSPECIFIED, static_cast<v1::LengthUnit>(7)}));
  h.set_scanner_kind(static_cast<v1::ScannerKind>(in.ConsumeIntegralInRange(0, 3)));
  // Mostly a few scans; now and then the limit or one beyond it.
  const uint32_t limit = service->max_scans_per_job;
  const int scans =
      static_cast<int>(in.PickValueInArray<uint32_t>({1, 1, 2, 3, 0, limit, limit + 1}));
  const int described = std::min(scans, 4);  // the rest are copies, to keep the cost small
  for (int s = 0; s < scans; ++s) {
    v1::ScanHeader* scan = h.add_scans();
    if (s < described) {
      FillScan(in, s, scan);
    } else {
      *scan = h.scans(s % described);
    }
  }
  v1::PipelineOptions* options = h.mutable_options();
  for (int n = in.ConsumeIntegralInRange(0, 4); n > 0; --n) options->add_stages(Pick(in, d.stages));
  for (int n = in.ConsumeIntegralInRange(0, 4); n > 0; --n) {
    const size_t param = in.ConsumeIntegralInRange<size_t>(0, d.params.size() - 1);
    (*options->mutable_params())[d.params[param]] = ParamValue(in, param);
  }
  options->set_include_removed(in.ConsumeBool());
  if (in.ConsumeBool()) {
    h.mutable_budget()->set_total_seconds(in.PickValueInArray({0.0, 0.001, 10.0, -1.0, kInf}));
    (*h.mutable_budget()->mutable_stage_seconds())[Pick(in, d.stages)] =
        in.PickValueInArray({0.0, 0.001, 10.0, -1.0});
  }
  const uint64_t max = service->max_points_per_job;
  h.set_total_points(in.PickValueInArray<uint64_t>(
      {points_to_send, points_to_send, points_to_send, points_to_send + 1, points_to_send - 1, 0,
       max, max + 1, std::numeric_limits<uint64_t>::max()}));
  return h;
}

// A chunk of `n` points: a wavy plane in scanlines (what the stages are made for), the fuzzer's
// own floats, or the plane with edge values mixed in; optional arrays now and then wrong.
v1::PointChunk Chunk(FuzzedDataProvider& in, size_t n, int scans, uint32_t first) {
  v1::PointChunk c;
  const int shape = in.ConsumeIntegralInRange(0, 2);
  const float step = in.ConsumeBool() ? ToFloat(Number(in)) : 0.5f;
  for (size_t k = 0; k < n; ++k) {
    const uint32_t i = first + static_cast<uint32_t>(k);
    float p[3] = {step * (i % 32), step * (i / 32), 0.05f * std::sin(0.7f * i)};
    if (shape == 1 || (shape == 2 && in.ConsumeIntegralInRange(0, 15) == 15)) {
      p[in.ConsumeIntegralInRange(0, 2)] = ToFloat(Number(in));
    }
    for (const float v : p) c.add_xyz(v);
  }
  if (in.ConsumeIntegralInRange(0, 7) == 7) c.add_xyz(1.f);  // not a multiple of 3
  const int arrays = in.ConsumeIntegral<uint8_t>();
  const size_t length = (arrays & 0x80) != 0 ? n + 1 : n;  // now and then one too many
  for (size_t k = 0; k < length; ++k) {
    const uint32_t i = first + static_cast<uint32_t>(k);
    if ((arrays & 1) != 0 || (scans > 1 && (arrays & 2) == 0)) {
      c.add_scan_index((arrays & 0x40) != 0 ? i % (scans + 1) : i % std::max(scans, 1));
    }
    if ((arrays & 4) != 0) c.add_scanline(i / 32);
    if ((arrays & 8) != 0) c.add_quality((arrays & 0x40) != 0 ? 1.5f : 0.9f);
    if ((arrays & 16) != 0) c.add_intensity(0.5f);
  }
  if ((arrays & 0x20) != 0 && in.ConsumeIntegralInRange(0, 7) == 7) c.set_flags("x");
  return c;
}

// The request messages of one call as bytes, and what a correct server makes of them.
struct Upload {
  std::vector<std::string> messages;
  bool header_seen = false;
  uint64_t declared = 0;       // the first header's total_points, as the server parses it
  uint64_t parsed_points = 0;  // in the chunks before the first message that cannot parse
  bool unparsable = false;     // a message that cannot parse was sent (the server reads no further)
  scanprep::StreamChecksum parsed_chunks;  // of the chunks before it
  bool ended = false;                      // an end message that parsed was sent
};

// Appends a message as sent, and counts its points as the server will see them.
void Add(Upload& upload, std::string bytes) {
  // The server parses with the same protobuf: a string that is not UTF-8 fails here too.
  v1::ProcessRequest parsed;
  if (!parsed.ParseFromString(bytes)) upload.unparsable = true;
  if (!upload.unparsable && parsed.has_points()) {
    upload.parsed_points += scanprep::ChunkPoints(parsed.points());
    upload.parsed_chunks.Add(parsed.points());
  }
  if (!upload.unparsable && parsed.has_end()) upload.ended = true;
  if (!upload.unparsable && parsed.has_header() && !upload.header_seen) {
    upload.header_seen = true;
    upload.declared = parsed.header().total_points();
  }
  upload.messages.push_back(std::move(bytes));
}

Upload MakeUpload(FuzzedDataProvider& in) {
  Upload upload;
  // The points planned for the chunks, so that the header can declare them.
  const int chunks = 1 + in.ConsumeIntegralInRange(0, kMaxMessages - 2);
  std::vector<size_t> sizes;
  uint64_t planned = 0;
  for (int c = 0; c < chunks; ++c) {
    sizes.push_back(kMaxChunkPoints - in.ConsumeIntegralInRange<size_t>(0, kMaxChunkPoints));
    planned += sizes.back();
  }
  // The order: -1 a header, k chunk k. Mostly the header first; now and then points before it,
  // or a second header after the first chunk.
  std::vector<int> plan;
  for (int c = 0; c < chunks; ++c) plan.push_back(c);
  const int order = in.ConsumeIntegralInRange(0, 7);
  plan.insert(plan.begin() + (order == 7 ? std::min(1, chunks) : 0), -1);
  if (order == 6) plan.insert(plan.begin() + std::min(2, chunks + 1), -1);

  int scans = 1;
  uint32_t sent = 0;
  for (const int step : plan) {
    v1::ProcessRequest request;
    if (step < 0) {
      *request.mutable_header() = Header(in, planned);
      if (!upload.header_seen) scans = request.header().scans_size();
    } else {
      *request.mutable_points() = Chunk(in, sizes[step], scans, sent);
      sent += static_cast<uint32_t>(sizes[step]);
    }
    std::string bytes = request.SerializeAsString();
    switch (in.ConsumeIntegralInRange(0, 15)) {
      case 13:
        bytes.resize(in.ConsumeIntegralInRange<size_t>(0, bytes.size()));
        break;  // cut
      case 14:
        bytes = in.ConsumeRandomLengthString(64);
        break;  // arbitrary bytes
      case 15:
        bytes.clear();
        break;  // an empty message
      default:
        break;
    }
    Add(upload, std::move(bytes));
  }
  // The end message: mostly the right one for the chunks that parsed, now and then none, a wrong
  // count or a wrong CRC-32.
  v1::ProcessRequest end;
  *end.mutable_end() = upload.parsed_chunks.End();
  switch (in.ConsumeIntegralInRange(0, 7)) {
    case 5:
      return upload;
    case 6:
      end.mutable_end()->set_points(end.end().points() + 1);
      break;
    case 7:
      end.mutable_end()->set_crc32(end.end().crc32() ^ 1);
      break;
    default:
      break;
  }
  Add(upload, end.SerializeAsString());
  return upload;
}

struct Outcome {
  grpc::Status status;
  std::vector<v1::ProcessResponse> responses;
};

// One call with raw request bytes (what no client library would send), like a hostile client.
Outcome Call(const std::vector<std::string>& messages) {
  const grpc::internal::RpcMethod method("/scanprep.v1.ScanPrep/Process",
                                         grpc::internal::RpcMethod::BIDI_STREAMING);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  std::unique_ptr<grpc::ClientReaderWriter<grpc::ByteBuffer, grpc::ByteBuffer>> stream(
      grpc::internal::ClientReaderWriterFactory<grpc::ByteBuffer, grpc::ByteBuffer>::Create(
          service->channel.get(), method, &context));
  for (const std::string& m : messages) {
    const grpc::Slice slice(m);
    grpc::ByteBuffer buffer(&slice, 1);
    if (!stream->Write(buffer)) break;
  }
  stream->WritesDone();
  Outcome outcome;
  grpc::ByteBuffer buffer;
  while (stream->Read(&buffer)) {
    v1::ProcessResponse response;
    Require(grpc::SerializationTraits<v1::ProcessResponse>::Deserialize(&buffer, &response).ok(),
            "every response parses");
    outcome.responses.push_back(std::move(response));
  }
  outcome.status = stream->Finish();
  return outcome;
}

void CheckOutcome(const Upload& upload, const Outcome& outcome) {
  const absl::Status status = scanprep::client::FromGrpc(outcome.status);
  if (!status.ok()) {
    Require(status.code() == absl::StatusCode::kInvalidArgument ||
                status.code() == absl::StatusCode::kResourceExhausted ||
                status.code() == absl::StatusCode::kDataLoss,
            "an error is INVALID_ARGUMENT, RESOURCE_EXHAUSTED or DATA_LOSS");
    const scanprep::client::CallErrorDetails details = scanprep::client::DetailsOf(status);
    Require(!details.reason.empty(), "every error carries an ErrorInfo reason");
    Require((status.code() == absl::StatusCode::kInvalidArgument) ==
                (details.field_violations.size() == 1),
            "an INVALID_ARGUMENT, and only it, names one field");
    return;
  }
  Require(upload.ended, "OK only with an end message");
  const size_t n = outcome.responses.size();
  Require(n >= 2 && outcome.responses[n - 2].has_report() && outcome.responses[n - 1].has_end(),
          "an OK call ends with its report, then its end message");
  const v1::Report& report = outcome.responses[n - 2].report();
  Require(report.points_received() == upload.declared, "OK only with the declared points");
  Require(report.points_received() == upload.parsed_points,
          "OK only with every point sent before the first unparsable message");
  uint64_t returned = 0;
  scanprep::StreamChecksum result;
  for (const v1::ProcessResponse& r : outcome.responses) {
    if (!r.has_points()) continue;
    const v1::PointChunk& c = r.points();
    returned += scanprep::ChunkPoints(c);
    result.Add(c);
    v1::PointChunk unpacked = c;  // packed results (header.result_arrays) read as repeated ones
    std::string bad_array;
    Require(scanprep::UnpackArrays(unpacked, bad_array).ok(), "well-formed packed results");
    for (const float v : unpacked.xyz()) Require(std::isfinite(v), "finite result coordinates");
  }
  Require(returned == report.points_returned(), "the result chunks hold the points returned");
  const v1::StreamEnd& end = outcome.responses[n - 1].end();
  Require(end.points() == returned && end.crc32() == result.crc32(),
          "the result's end message matches its chunks");
  Require(report.points_returned() <= report.points_processed(),
          "no more points returned than processed");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // protobuf logs every invalid UTF-8 string it parses or serializes: noise at this rate.
  google::protobuf::SetLogHandler(nullptr);
  service = new Service;
  scanprep::server::ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.threads = 1;
  auto started = scanprep::server::ScanPrepServer::Start(options);
  Require(started.ok(), "the server starts");
  service->server = std::move(*started);
  service->channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", service->server->port()),
                                         grpc::InsecureChannelCredentials());
  service->dictionary = MakeDictionary();
  service->max_points_per_job = options.limits.max_points_per_job;
  service->max_scans_per_job = options.limits.max_scans_per_job;
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  for (int call = 0; call < kMaxCalls && in.remaining_bytes() > 0; ++call) {
    const Upload upload = MakeUpload(in);
    CheckOutcome(upload, Call(upload.messages));
  }
  return 0;
}
