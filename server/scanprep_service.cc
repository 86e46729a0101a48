// SPDX-License-Identifier: Apache-2.0
#include "server/scanprep_service.h"

#include <malloc.h>

#include <chrono>
#include <new>
#include <optional>

#include <google/protobuf/util/time_util.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/stages/stage.h"
#include "core/stages/warning.h"
#include "server/admission/memory_reservation.h"
#include "server/transport/client_identity.h"
#include "wire/chunk_arrays.h"
#include "wire/convert.h"
#include "wire/error_details.h"
#include "wire/stream_checksum.h"

namespace scanprep::server {
namespace {

// How often the waiting RPC thread looks at cancellation and forwards progress.
constexpr std::chrono::milliseconds kPollInterval(25);

absl::Time CallDeadline(const grpc::ServerContext& context) {
  const auto deadline = context.deadline();
  return deadline == std::chrono::system_clock::time_point::max() ? absl::InfiniteFuture()
                                                                  : absl::FromChrono(deadline);
}

// The server's deadline is the client's timeout counted from when the call's headers arrived, so
// it falls after the client's own by the headers' delay, which reaches tens of milliseconds on a
// loaded machine: a cancellation arriving this close before the server's deadline is the client's
// deadline timer firing first.
constexpr absl::Duration kDeadlineSkew = absl::Milliseconds(250);

using google::protobuf::util::TimeUtil;

// glibc keeps freed memory resident in its per-thread arenas, and the next job's threads may
// allocate from other arenas: without handing the pages back, a server running one job after
// another grew past the sum of the jobs' estimates (303 MB against a 300 MB capacity with 8 arena
// threads, 8 jobs of 250,000 points two at a time). malloc_trim returns the free pages of every
// arena, in milliseconds.
//
// Not under AddressSanitizer or ThreadSanitizer: their runtimes replace malloc with their own
// allocator but do not intercept malloc_trim, so the call would walk glibc's arenas, which hold
// none of the job's memory (CI once crashed with a SEGV inside malloc_trim under ASan). clang
// says so with __has_feature, gcc with __SANITIZE_*__.
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define SCANPREP_SANITIZER_ALLOCATOR
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SCANPREP_SANITIZER_ALLOCATOR
#endif
#ifdef SCANPREP_SANITIZER_ALLOCATOR
constexpr bool kMallocIsGlibcs = false;
#else
constexpr bool kMallocIsGlibcs = true;
#endif

class ReturnFreedMemoryOnExit {
 public:
  ReturnFreedMemoryOnExit() = default;
  ReturnFreedMemoryOnExit(const ReturnFreedMemoryOnExit&) = delete;
  ReturnFreedMemoryOnExit& operator=(const ReturnFreedMemoryOnExit&) = delete;
  ~ReturnFreedMemoryOnExit() {
    if constexpr (kMallocIsGlibcs) malloc_trim(0);
  }
};

}  // namespace

grpc::Status ScanPrepService::Gone(const grpc::ServerContext& context,
                                   std::string_view phase) const {
  if (runner_.cancelled_all()) {
    return ToGrpc(WithReason(
        absl::UnavailableError(absl::StrCat("the server shut down at the end of its grace period "
                                            "during ",
                                            std::string(phase), "; retry on another replica")),
        "SHUTTING_DOWN", kRetryOnAnotherReplica));
  }
  if (absl::Now() + kDeadlineSkew >= CallDeadline(context)) {
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                        absl::StrCat("the call's deadline passed during ", std::string(phase)));
  }
  return grpc::Status(
      grpc::StatusCode::CANCELLED,
      absl::StrCat("the call was cancelled by the client during ", std::string(phase)));
}

grpc::Status ScanPrepService::Ended(const grpc::ServerContext& context,
                                    const IdleWatch::Call& watch, std::string_view phase) const {
  if (const std::string reason = watch.reason(); !reason.empty()) {
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                        absl::StrCat(reason, "; the server ended the call"));
  }
  return Gone(context, phase);
}

grpc::Status ScanPrepService::Process(
    grpc::ServerContext* context,
    grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>* stream) {
  BidiJobStream job_stream(stream);
  return Serve(context, &job_stream);
}

grpc::Status ScanPrepService::ProcessUnary(grpc::ServerContext* context,
                                           const v1::ProcessUnaryRequest* request,
                                           v1::ProcessUnaryResponse* response) {
  // The request is the service's to consume: its points move into the job piece by piece.
  UnaryJobStream job_stream(const_cast<v1::ProcessUnaryRequest&>(*request), *response,
                            kRecommendedChunkPoints);
  return Serve(context, &job_stream);
}

grpc::Status ScanPrepService::Serve(grpc::ServerContext* context, Stream* stream) {
  const RpcMethod& method = stream->method();
  metrics_.RpcStarted(method);
  // Read now: gRPC reports a cancelled call's peer as "unknown".
  const std::string peer = context->peer();
  CallRecord record{.start = absl::Now(), .client = ClientHost(*context, trusted_proxies_)};
  grpc::Status status;
  // The optional per-host cap, counted before anything is read.
  if (auto lease = peers_.Acquire(record.client); !lease.ok()) {
    status = Refuse(lease.status());
  } else if (absl::Status corrupted = stream->Check(); !corrupted.ok()) {
    status = Refuse(corrupted);
  } else {
    std::optional<AdmissionQueue::Ticket> ticket;
    try {
      status = ProcessJob(context, stream, record, ticket);
    } catch (const std::bad_alloc&) {
      status = grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                            "the server ran out of memory holding this job");
    }
    if (const uint64_t unsent = stream->unsent_bytes(); status.ok() && unsent > 0) {
      answers_.Keep(context,
                    {.ticket = std::move(ticket),
                     .lease = std::move(*lease),
                     .peer = peer,
                     .client = record.client,
                     .job_id = record.job_id},
                    unsent);
    }
  }
  const absl::Duration elapsed = absl::Now() - record.start;
  metrics_.RpcHandled(method, status.error_code(), absl::ToDoubleSeconds(elapsed));
  LogCall(peer, record, status, elapsed);
  return status;
}

void ScanPrepService::LogCall(const std::string& peer, const CallRecord& record,
                              const grpc::Status& status, absl::Duration elapsed) {
  // A client that hangs up is routine; every other failure is worth a look.
  const bool routine = status.ok() || status.error_code() == grpc::StatusCode::CANCELLED;
  std::vector<LogField> fields = {
      {"peer", peer},
      {"client", record.client},
      {"job", record.job_id, kLoggedClientTextBytes},
      {"points", static_cast<int64_t>(record.points)},
      {"status", absl::StatusCodeToString(static_cast<absl::StatusCode>(status.error_code()))}};
  if (!status.ok()) fields.push_back({"message", status.error_message(), kLoggedMessageBytes});
  fields.push_back({"seconds", absl::ToDoubleSeconds(elapsed)});
  log_.Write(routine ? CallLog::kInfo : CallLog::kWarning, "process", fields);
}

bool ScanPrepService::Send(Stream* stream, IdleWatch::Call& watch,
                           const v1::ProcessResponse& response) {
  metrics_.ResponseSent(stream->method(), response.ByteSizeLong(),
                        response.has_points() ? ChunkPoints(response.points()) : 0);
  watch.Expect(timeouts_.idle, "idle_timeout",
               absl::StrCat("the client did not read the next ",
                            response.has_points()     ? "result chunk"
                            : response.has_progress() ? "progress message"
                            : response.has_report()   ? "report"
                                                      : "response"));
  const bool written = stream->Write(response);
  watch.Pause();  // until the next write, the server is busy, not the client
  return written;
}

bool ScanPrepService::SendProgress(Stream* stream, IdleWatch::Call& watch,
                                   v1::Progress::Phase phase, double fraction, uint64_t points) {
  v1::ProcessResponse response;
  v1::Progress* p = response.mutable_progress();
  p->set_phase(phase);
  p->set_fraction(fraction);
  p->set_points(points);
  return Send(stream, watch, response);
}

bool ScanPrepService::SendStageProgress(Stream* stream, IdleWatch::Call& watch,
                                        const StageProgress& stage) {
  v1::ProcessResponse response;
  v1::Progress* p = response.mutable_progress();
  p->set_phase(v1::Progress::PHASE_PROCESSING);
  p->set_stage(stage.stage);
  p->set_fraction(stage.fraction);
  p->set_stage_index(stage.stage_index);
  p->set_stage_count(stage.stage_count);
  p->set_job_fraction(stage.job_fraction);
  return Send(stream, watch, response);
}

uint64_t ScanPrepService::UploadBytes(const Stream& stream, const JobAssembler& assembler) const {
  return stream.held_bytes() + assembler.PeakBytesWith(limits_.max_chunk_points) +
         kJobOverheadBytes;
}

grpc::Status ScanPrepService::Refuse(const absl::Status& status) {
  if (const std::optional<Warning> warning = FailedWarning(status)) {
    metrics_.FailedOnWarning(warning->code);  // the upload's POINTS_INVALID under strict
    return ToGrpc(status);
  }
  metrics_.Rejected(status.code() == absl::StatusCode::kResourceExhausted ? RejectReason::kLimit
                                                                          : RejectReason::kInvalid);
  return ToGrpc(status);
}

grpc::Status ScanPrepService::ProcessJob(grpc::ServerContext* context, Stream* stream,
                                         CallRecord& record,
                                         std::optional<AdmissionQueue::Ticket>& ticket) {
  // Destroyed in this order: the job's data, then the memory it freed is returned to the
  // system, then (the caller's) the slot frees its reservation.
  const ReturnFreedMemoryOnExit return_freed_memory;
  absl::StatusOr<AssembledJob> job = absl::UnknownError("not uploaded");
  IdleWatch::Call watch = idle_.Watch(context);
  // By hand: the status macros take absl::Status, and these are the call's grpc::Status.
  if (grpc::Status s = Upload(context, stream, watch, record, ticket, job); !s.ok()) return s;
  if (grpc::Status s = TakeSlot(context, watch, *ticket, job->job_id); !s.ok()) return s;
  // The whole claim (TakeSlot reserved it), for the memory guard's message.
  const uint64_t reservation = ticket->reserved_bytes();
  std::shared_ptr<RunningJob> running =
      runner_.Start(std::move(job->cloud), std::move(job->options), reservation);
  if (grpc::Status s = Relay(context, stream, watch, *running); !s.ok()) return s;
  metrics_.JobProcessed(*running->result());
  return Download(context, stream, watch, *job, *running, record);
}

grpc::Status ScanPrepService::Upload(grpc::ServerContext* context, Stream* stream,
                                     IdleWatch::Call& watch, CallRecord& record,
                                     std::optional<AdmissionQueue::Ticket>& ticket,
                                     absl::StatusOr<AssembledJob>& job) {
  // Validates each message as it arrives; the first error ends the call without reading the
  // rest. The call takes a ticket once its header is valid, before any points arrive, and
  // reserves memory for its data as the points arrive (admission.h); it holds no slot.
  absl::Time upload_start;
  const std::function<bool()> cancelled = [context] { return context->IsCancelled(); };
  JobAssembler assembler(limits_);
  v1::ProcessRequest request;
  watch.Expect(timeouts_.header, "header_timeout", "the header did not arrive");
  while (stream->Read(&request)) {
    const size_t bytes = request.ByteSizeLong();
    metrics_.RequestReceived(stream->method(), bytes,
                             request.has_points() ? ChunkPoints(request.points()) : 0);
    watch.Transferred(bytes);
    absl::Status added = assembler.Add(request);
    record.job_id = assembler.job_id();
    record.points = assembler.points_received();
    if (!added.ok()) return Refuse(added);
    watch.Pause();              // waiting for memory is the server's time, not the client's
    if (!ticket.has_value()) {  // the assembler accepts only a header first
      auto admitted =
          admission_.Admit(record.client,
                           stream->held_bytes() + EstimateJobBytes(assembler.total_points(),
                                                                   assembler.options().params),
                           UploadBytes(*stream, assembler), CallDeadline(*context), cancelled);
      if (!admitted.ok()) {
        // Cancelled while waiting: by the client, or by gRPC because the deadline passed.
        return admitted.status().code() == absl::StatusCode::kCancelled
                   ? Gone(*context, "the wait for memory")
                   : ToGrpc(admitted.status());
      }
      ticket.emplace(std::move(*admitted));
      upload_start = absl::Now();
      watch.ExpectRate(IdleWatch::Direction::kUpload, timeouts_.min_upload_rate, timeouts_.idle,
                       "min_upload_rate");
      watch.Expect(timeouts_.idle, "idle_timeout", "the first chunk did not arrive");
      continue;
    }
    if (absl::Status reserved = ticket->Reserve(UploadBytes(*stream, assembler), cancelled);
        !reserved.ok()) {
      return reserved.code() == absl::StatusCode::kCancelled ? Gone(*context, "the wait for memory")
                                                             : ToGrpc(reserved);
    }
    const uint64_t received = assembler.points_received();
    const double fraction = static_cast<double>(received) / assembler.total_points();
    if (!SendProgress(stream, watch, v1::Progress::PHASE_UPLOAD, fraction, received)) {
      return Ended(*context, watch, "upload");
    }
    watch.Expect(timeouts_.idle, "idle_timeout",
                 absl::StrCat("the next message after ", received, " points did not arrive"));
  }
  watch.Pause();
  if (context->IsCancelled()) return Ended(*context, watch, "upload");
  job = assembler.Finish();
  if (!job.ok()) return Refuse(job.status());
  metrics_.PhaseEnded(Phase::kUpload, absl::ToDoubleSeconds(absl::Now() - upload_start));
  return grpc::Status::OK;
}

grpc::Status ScanPrepService::TakeSlot(grpc::ServerContext* context, IdleWatch::Call& watch,
                                       AdmissionQueue::Ticket& ticket, const std::string& job_id) {
  // The job never runs on less than its whole claim; the client waits (the call is paused).
  watch.StopRate();  // the upload's; the wait and the processing are the server's time
  const std::function<bool()> cancelled = [context] { return context->IsCancelled(); };
  const absl::Status taken = ticket.TakeSlot(cancelled);
  if (taken.code() == absl::StatusCode::kCancelled) return Gone(*context, "the wait for a slot");
  if (taken.ok() && on_slot_) on_slot_(job_id, cancelled);
  return ToGrpc(taken);
}

grpc::Status ScanPrepService::Relay(grpc::ServerContext* context, Stream* stream,
                                    IdleWatch::Call& watch, RunningJob& running) {
  // The job runs on the shared arena; this thread only relays progress and cancellation.
  bool client_gone = false;
  for (bool done = false; !done;) {
    done = running.WaitFor(kPollInterval);
    if (!client_gone && context->IsCancelled()) {
      client_gone = true;
      running.Cancel();
    }
    for (const StageProgress& p : running.DrainProgress()) {
      if (client_gone) break;
      if (!SendStageProgress(stream, watch, p)) {
        client_gone = true;
        running.Cancel();
      }
    }
  }
  if (client_gone) return Ended(*context, watch, "processing");
  const absl::StatusOr<PipelineReport>& result = running.result();
  if (!result.ok()) {
    if (runner_.cancelled_all()) return Gone(*context, "processing");
    if (const std::optional<Warning> warning = FailedWarning(result.status())) {
      metrics_.FailedOnWarning(warning->code);
    }
    return ToGrpc(FailedOnWarningError(OptionsError(result.status())));
  }
  return grpc::Status::OK;
}

grpc::Status ScanPrepService::Download(grpc::ServerContext* context, Stream* stream,
                                       IdleWatch::Call& watch, const AssembledJob& job,
                                       const RunningJob& running, const CallRecord& record) {
  // The kept points (all of them with include_removed; none with result_arrays NONE), the
  // report, then the end message with the points' count and CRC-32. The client must read them at
  // the minimum rate: a Write returns once its message is in gRPC's flow-control window, so the
  // bytes written are what the client took, give or take one window.
  const absl::Time download_start = absl::Now();
  watch.ExpectRate(IdleWatch::Direction::kDownload, timeouts_.min_download_rate, timeouts_.idle,
                   "min_download_rate");
  const PointCloud& cloud = running.cloud();
  std::vector<uint32_t> indices;
  indices.reserve(cloud.size());
  for (uint32_t i = 0; job.return_points && i < cloud.size(); ++i) {
    if (job.include_removed || !cloud.removed(i)) indices.push_back(i);
  }
  StreamChecksum sent;
  for (size_t begin = 0; begin < indices.size(); begin += kRecommendedChunkPoints) {
    const size_t end = std::min(indices.size(), begin + kRecommendedChunkPoints);
    v1::ProcessResponse response;
    v1::PointChunk& chunk = *response.mutable_points();
    ResultChunk(cloud, indices, begin, end, job.mm_per_unit, &chunk);
    // Positions are below header.total_points, itself within max_points_per_job < 2^32.
    for (size_t k = begin; job.return_source_index && k < end; ++k) {
      chunk.add_source_index(static_cast<uint32_t>(job.upload_positions.Of(indices[k])));
    }
    if (job.packed_results) PackArrays(chunk);
    sent.Add(chunk);
    const bool written = Send(stream, watch, response);
    watch.Transferred(response.ByteSizeLong());
    if (!written || !SendProgress(stream, watch, v1::Progress::PHASE_DOWNLOAD,
                                  static_cast<double>(end) / indices.size(), end)) {
      return Ended(*context, watch, "download");
    }
  }
  v1::ProcessResponse response;
  FillReport(job, *running.result(), indices.size(), record, *response.mutable_report());
  if (!Send(stream, watch, response)) return Ended(*context, watch, "download");
  response.Clear();
  *response.mutable_end() = sent.End();
  if (!Send(stream, watch, response)) return Ended(*context, watch, "download");
  metrics_.PhaseEnded(Phase::kDownload, absl::ToDoubleSeconds(absl::Now() - download_start));
  return grpc::Status::OK;
}

void ScanPrepService::FillReport(const AssembledJob& job, const PipelineReport& result,
                                 size_t returned, const CallRecord& record, v1::Report& report) {
  report.set_job_id(job.job_id);
  report.set_points_received(job.points_received);
  report.set_points_invalid(job.points_invalid);
  report.set_points_processed(job.points_received - job.points_invalid);
  report.set_points_returned(returned);
  for (const Warning& w : job.warnings) AddWarning(w, &report);
  ReportToProto(result, &report);
  report.mutable_labels()->insert(job.labels.begin(), job.labels.end());
  report.set_preset(job.preset);
  report.set_server_version(SCANPREP_VERSION);
  *report.mutable_started() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(record.start));
  *report.mutable_finished() = TimeUtil::NanosecondsToTimestamp(absl::ToUnixNanos(absl::Now()));
}

grpc::Status ScanPrepService::GetInfo(grpc::ServerContext*, const v1::GetInfoRequest*,
                                      v1::GetInfoResponse* info) {
  const absl::Time start = absl::Now();
  metrics_.RpcStarted(kGetInfoRpc);
  info->set_version(SCANPREP_VERSION);
  v1::Limits* limits = info->mutable_limits();
  limits->set_max_points_per_job(limits_.max_points_per_job);
  limits->set_max_chunk_points(limits_.max_chunk_points);
  limits->set_max_concurrent_jobs(admission_.max_concurrent_jobs());
  limits->set_max_queued_jobs(admission_.max_queued_jobs());
  limits->set_recommended_chunk_points(kRecommendedChunkPoints);
  limits->set_max_bytes_per_call(limits_.max_bytes_per_call);
  limits->set_max_calls_per_peer(peers_.max_calls_per_peer());
  limits->set_max_scans_per_job(limits_.max_scans_per_job);
  limits->set_max_plan_cost(limits_.max_plan_cost);
  limits->set_max_message_bytes(limits_.max_message_bytes);
  limits->set_max_labels(kMaxLabels);
  limits->set_max_header_string_bytes(kMaxHeaderStringBytes);
  limits->set_header_timeout_seconds(absl::ToDoubleSeconds(timeouts_.header));
  limits->set_idle_timeout_seconds(absl::ToDoubleSeconds(timeouts_.idle));
  limits->set_min_upload_bytes_per_second(timeouts_.min_upload_rate);
  // The field keeps the name it had before the capacity was called one (a wire name).
  limits->set_memory_budget_bytes(admission_.memory_capacity_bytes());
  limits->set_bytes_per_point(BaseBytesPerPoint());
  const std::vector<std::string> defaults = DefaultStages();
  for (const StageInfo& stage : StageRegistry()) {
    v1::StageInfo* s = info->add_stages();
    s->set_name(stage.name);
    s->set_summary(stage.summary);
    s->set_default_enabled(std::find(defaults.begin(), defaults.end(), stage.name) !=
                           defaults.end());
  }
  for (const ParamSpec& spec : AllParamSpecs()) ParamSpecToProto(spec, info->add_parameters());
  for (const Preset& preset : *limits_.presets) PresetToProto(preset, info->add_presets());
  info->set_default_budget_seconds(limits_.default_budget_seconds);
  for (WarningCode code : StrictWarningCodes()) {
    info->add_strict_warning_codes(WarningCodeToProto(code));
  }
  for (const auto& [stage, seconds] : limits_.default_stage_budget_seconds) {
    (*info->mutable_default_stage_budget_seconds())[stage] = seconds;
  }
  metrics_.RpcHandled(kGetInfoRpc, grpc::StatusCode::OK,
                      absl::ToDoubleSeconds(absl::Now() - start));
  return grpc::Status::OK;
}

}  // namespace scanprep::server
