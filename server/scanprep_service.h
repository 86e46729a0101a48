// The ScanPrep gRPC service: protocol handling around JobAssembler, AdmissionQueue and JobRunner.
#pragma once

#include <string>

#include <grpcpp/grpcpp.h>

#include "scanprep/v1/scanprep.grpc.pb.h"
#include "server/admission.h"
#include "server/job_assembler.h"
#include "server/job_runner.h"
#include "server/service_metrics.h"

namespace scanprep::server {

// Points per result chunk; half the per-chunk limit, about 0.8 MiB with every array filled.
inline constexpr uint32_t kRecommendedChunkPoints = 32'768;

class ScanPrepService final : public v1::ScanPrep::Service {
 public:
  ScanPrepService(JobLimits limits, AdmissionQueue& admission, JobRunner& runner,
                  ServiceMetrics& metrics)
      : limits_(std::move(limits)), admission_(admission), runner_(runner), metrics_(metrics) {}

  grpc::Status Process(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>* stream) override;
  grpc::Status GetInfo(grpc::ServerContext* context, const v1::GetInfoRequest* request,
                       v1::Info* info) override;

 private:
  using Stream = grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>;
  grpc::Status ProcessJob(grpc::ServerContext* context, Stream* stream);
  // Writes one response and counts it; false when the client is gone.
  bool Send(Stream* stream, const v1::ProcessResponse& response);
  bool SendProgress(Stream* stream, v1::Progress::Phase phase, std::string_view stage,
                    double fraction, uint64_t points);
  // The status for a job the assembler refused, counted as a rejection.
  grpc::Status Refuse(const absl::Status& status);

  JobLimits limits_;
  AdmissionQueue& admission_;
  JobRunner& runner_;
  ServiceMetrics& metrics_;
};

}  // namespace scanprep::server
