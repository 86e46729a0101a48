// SPDX-License-Identifier: Apache-2.0
// The ScanPrep gRPC service: protocol handling around JobAssembler, AdmissionQueue and JobRunner.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include <grpcpp/grpcpp.h>

#include "scanprep/v1/scanprep.grpc.pb.h"
#include "server/admission/admission.h"
#include "server/admission/peer_limiter.h"
#include "server/job/job_assembler.h"
#include "server/job/job_runner.h"
#include "server/job_stream.h"
#include "server/metrics/service_metrics.h"
#include "server/transport/call_log.h"
#include "server/transport/cidr.h"
#include "server/transport/idle_watch.h"
#include "server/unsent_answers.h"

namespace scanprep::server {

// Points per result chunk; half the per-chunk limit, about 0.8 MiB with every array filled.
inline constexpr uint32_t kRecommendedChunkPoints = 32'768;

// How long a client may keep the server waiting for its next upload message, or for it to read
// the next response.
struct StreamTimeouts {
  absl::Duration header = absl::Seconds(10);  // from the call's start to its header
  // Between later upload messages; and the longest one response may wait to be read.
  absl::Duration idle = absl::Seconds(30);
  // Bytes per second the upload must keep up with from its admission on, after a first `idle`,
  // judged over a sliding window of twice `idle` (IdleWatch::Call::ExpectRate).
  double min_upload_rate = 64 * 1024;
  // Result bytes per second the client must read from the download's start, judged alike.
  double min_download_rate = 64 * 1024;
};

// TEST HOOK (ServerOptions::on_slot): runs on a Process call's thread once its job holds a slot,
// before the job starts, with the job's id; a test blocks in it, until `cancelled()`, to hold
// the slot.
using SlotHook =
    std::function<void(std::string_view job_id, const std::function<bool()>& cancelled)>;

class ScanPrepService final : public v1::ScanPrep::Service {
 public:
  // Calls from an address in `trusted_proxies` count as from the client they forwarded
  // (client_identity.h).
  ScanPrepService(JobLimits limits, StreamTimeouts timeouts, std::vector<Cidr> trusted_proxies,
                  AdmissionQueue& admission, JobRunner& runner, ServiceMetrics& metrics,
                  PeerLimiter& peers, CallLog& log, SlotHook on_slot = {})
      : limits_(std::move(limits)),
        timeouts_(timeouts),
        trusted_proxies_(std::move(trusted_proxies)),
        admission_(admission),
        runner_(runner),
        metrics_(metrics),
        peers_(peers),
        log_(log),
        on_slot_(std::move(on_slot)),
        answers_(idle_, log, timeouts.idle, timeouts.min_download_rate) {}

  // Holds a unary call's slot, reservation and per-host place until its answer has left
  // (ServerBuilder::experimental().SetInterceptorCreators takes its interceptor).
  UnsentAnswers& unsent_answers() { return answers_; }

  grpc::Status Process(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>* stream) override;
  grpc::Status ProcessUnary(grpc::ServerContext* context, const v1::ProcessUnaryRequest* request,
                            v1::ProcessUnaryResponse* response) override;
  grpc::Status GetInfo(grpc::ServerContext* context, const v1::GetInfoRequest* request,
                       v1::GetInfoResponse* info) override;

 private:
  using Stream = JobStream;
  // What the log line of a Process call says besides its status.
  struct CallRecord {
    absl::Time start;    // when the call arrived
    std::string client;  // the client host (client_identity.h)
    std::string job_id;
    uint64_t points = 0;
  };
  // A job call (Process or ProcessUnary, through `stream`) from its per-host cap to its log line.
  grpc::Status Serve(grpc::ServerContext* context, Stream* stream);
  // A Process call's phases: upload (validated as it arrives, a ticket taken once the header is
  // valid and a slot once the data has arrived), processing (progress relayed, cancellation passed
  // on), download (points, report, end). Each returns OK to go on, else the call's status. One
  // IdleWatch::Call watches the client through all three.
  // `ticket`: the call's place and slot, the caller's so that a unary call keeps it until its
  // answer has left.
  grpc::Status ProcessJob(grpc::ServerContext* context, Stream* stream, CallRecord& record,
                          std::optional<AdmissionQueue::Ticket>& ticket);
  grpc::Status Upload(grpc::ServerContext* context, Stream* stream, IdleWatch::Call& watch,
                      CallRecord& record, std::optional<AdmissionQueue::Ticket>& ticket,
                      absl::StatusOr<AssembledJob>& job);
  // After the upload: waits for a slot with the job's whole claim reserved.
  grpc::Status TakeSlot(grpc::ServerContext* context, IdleWatch::Call& watch,
                        AdmissionQueue::Ticket& ticket, const std::string& job_id);
  grpc::Status Relay(grpc::ServerContext* context, Stream* stream, IdleWatch::Call& watch,
                     RunningJob& running);
  grpc::Status Download(grpc::ServerContext* context, Stream* stream, IdleWatch::Call& watch,
                        const AssembledJob& job, const RunningJob& running,
                        const CallRecord& record);
  static void FillReport(const AssembledJob& job, const PipelineReport& result, size_t returned,
                         const CallRecord& record, v1::Report& report);
  void LogCall(const std::string& peer, const CallRecord& record, const grpc::Status& status,
               absl::Duration elapsed);
  // Writes one response and counts it; false when the client is gone. The write must complete
  // within the idle timeout (`watch`): a client that stops reading blocks it once gRPC's
  // flow-control window is full.
  bool Send(Stream* stream, IdleWatch::Call& watch, const v1::ProcessResponse& response);
  // Upload or download progress: the phase's fraction and the points moved so far.
  bool SendProgress(Stream* stream, IdleWatch::Call& watch, v1::Progress::Phase phase,
                    double fraction, uint64_t points);
  // Processing progress: the stage, its place in the plan and the job's fraction.
  bool SendStageProgress(Stream* stream, IdleWatch::Call& watch, const StageProgress& stage);
  // The status of a call that ended during `phase` other than by its own fault: the server's
  // grace period ended (UNAVAILABLE), its deadline passed, or the client cancelled it or vanished.
  grpc::Status Gone(const grpc::ServerContext& context, std::string_view phase) const;
  // The status of a call that ended during `phase` without an error of its own: why `watch` ended
  // it (DEADLINE_EXCEEDED; the client sees only CANCELLED, the log and metrics see the reason),
  // else Gone.
  grpc::Status Ended(const grpc::ServerContext& context, const IdleWatch::Call& watch,
                     std::string_view phase) const;
  // What an upload must have reserved before its next message is read: its arrays as they grow
  // by one more chunk at the largest size (JobAssembler::PeakBytesWith), one message with gRPC's
  // buffers (kJobOverheadBytes) and what its stream holds (JobStream::held_bytes). Its data, not
  // the declared job's estimate, which it reserves only when it takes its slot.
  uint64_t UploadBytes(const Stream& stream, const JobAssembler& assembler) const;
  // The status for a job the assembler refused, counted as a rejection.
  grpc::Status Refuse(const absl::Status& status);

  JobLimits limits_;
  StreamTimeouts timeouts_;
  const std::vector<Cidr> trusted_proxies_;
  IdleWatch idle_;
  AdmissionQueue& admission_;
  JobRunner& runner_;
  ServiceMetrics& metrics_;
  PeerLimiter& peers_;
  CallLog& log_;
  const SlotHook on_slot_;
  UnsentAnswers answers_;
};

}  // namespace scanprep::server
