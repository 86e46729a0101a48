// The ScanPrep gRPC service: protocol handling around JobAssembler and JobRunner.
#pragma once

#include <string>

#include <grpcpp/grpcpp.h>

#include "scanprep/v1/scanprep.grpc.pb.h"
#include "server/job_assembler.h"
#include "server/job_runner.h"

namespace scanprep::server {

// Points per result chunk; half the per-chunk limit, about 0.8 MiB with every array filled.
inline constexpr uint32_t kRecommendedChunkPoints = 32'768;

class ScanPrepService final : public v1::ScanPrep::Service {
 public:
  ScanPrepService(JobLimits limits, JobRunner& runner) : limits_(limits), runner_(runner) {}

  grpc::Status Process(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>* stream) override;
  grpc::Status GetInfo(grpc::ServerContext* context, const v1::GetInfoRequest* request,
                       v1::Info* info) override;

 private:
  using Stream = grpc::ServerReaderWriter<v1::ProcessResponse, v1::ProcessRequest>;
  grpc::Status ProcessJob(grpc::ServerContext* context, Stream* stream);

  JobLimits limits_;
  JobRunner& runner_;
};

}  // namespace scanprep::server
