// SPDX-License-Identifier: Apache-2.0
// Runs pipelines on one shared TBB arena, never on gRPC threads. How many run at once is the
// AdmissionQueue's business.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/pipeline/pipeline.h"
#include "core/stages/report.h"

namespace scanprep::server {

// Sees every progress event on the processing thread before it is queued for the client; a
// test hook that can hold a job inside a chosen stage.
using ProgressHook = std::function<void(std::string_view stage, double fraction)>;

struct StageProgress {
  std::string stage;
  double fraction = 0;
  uint32_t stage_index = 0, stage_count = 0;
  double job_fraction = 0;
};

// One job's state shared by the arena task that computes it and the RPC thread that waits for
// it. The job owns its cloud, so the task never outlives the data it works on.
class RunningJob {
 public:
  // `reservation_bytes`: the memory admission reserved for the job (memory_reservation.h).
  RunningJob(PointCloud cloud, PipelineOptions options, ProgressHook hook,
             uint64_t reservation_bytes)
      : cloud_(std::move(cloud)),
        options_(std::move(options)),
        hook_(std::move(hook)),
        reservation_bytes_(reservation_bytes) {}

  void Cancel() { cancel_.Cancel(); }
  // Cancels the job and makes `why` its result in place of the cancellation the stages return
  // (the memory guard's reason); a job that finished already keeps its result.
  void End(absl::Status why);
  // Whether the pipeline finished (or failed): its stages hold no more memory.
  bool done() const;
  uint64_t reservation_bytes() const { return reservation_bytes_; }
  // True once the pipeline finished (or failed); waits at most `timeout`.
  bool WaitFor(std::chrono::milliseconds timeout);
  // Progress events since the last call; consecutive updates of one stage are coalesced.
  std::vector<StageProgress> DrainProgress();
  // Valid after WaitFor() returned true.
  const absl::StatusOr<PipelineReport>& result() const { return *result_; }
  const PointCloud& cloud() const { return cloud_; }

 private:
  friend class JobRunner;
  void Run();
  void OnProgress(const ProgressEvent& event);

  PointCloud cloud_;
  PipelineOptions options_;
  ProgressHook hook_;
  const uint64_t reservation_bytes_;
  CancelToken cancel_;
  mutable std::mutex mu_;
  absl::Status ended_;  // End()'s reason; OK unless ended
  std::condition_variable done_cv_;
  std::optional<absl::StatusOr<PipelineReport>> result_;
  std::vector<StageProgress> progress_;
};

class JobRunner {
 public:
  // `threads` = arena concurrency; 0 = hardware concurrency.
  explicit JobRunner(int threads, ProgressHook hook = {});

  // Starts the job, which reserved `reservation_bytes`, on the arena; cancelled at once after
  // CancelAll().
  std::shared_ptr<RunningJob> Start(PointCloud cloud, PipelineOptions options,
                                    uint64_t reservation_bytes);
  // The jobs whose pipeline has not finished, in the order they started.
  std::vector<std::shared_ptr<RunningJob>> Processing() const;
  // The server's grace period ended: cancels every running job through its CancelToken, without
  // waiting for the RPC threads that watch them to notice.
  void CancelAll();
  bool cancelled_all() const;

  int threads() const { return threads_; }

 private:
  int threads_;
  ProgressHook hook_;
  mutable std::mutex mu_;
  std::vector<std::weak_ptr<RunningJob>> jobs_;  // started, possibly finished
  bool cancelled_all_ = false;
  // TBB caps its workers at hardware concurrency - 1 by default (the rest is kept for a master
  // thread); every job here is enqueued, so the arena needs all `threads` as workers.
  tbb::global_control workers_;
  tbb::task_arena arena_;
};

}  // namespace scanprep::server
