// Runs pipelines on one shared TBB arena, never on gRPC threads, and bounds how many jobs the
// server holds at once.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "absl/status/statusor.h"
#include "core/cancel.h"
#include "core/pipeline.h"
#include "core/point_cloud.h"
#include "core/report.h"

namespace scanprep::server {

struct StageProgress {
  std::string stage;
  double fraction = 0;
};

// One job's state shared by the arena task that computes it and the RPC thread that waits for
// it. The job owns its cloud, so the task never outlives the data it works on.
class RunningJob {
 public:
  RunningJob(PointCloud cloud, PipelineOptions options)
      : cloud_(std::move(cloud)), options_(std::move(options)) {}

  void Cancel() { cancel_.Cancel(); }
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
  void OnProgress(std::string_view stage, double fraction);

  PointCloud cloud_;
  PipelineOptions options_;
  CancelToken cancel_;
  std::mutex mu_;
  std::condition_variable done_cv_;
  std::optional<absl::StatusOr<PipelineReport>> result_;
  std::vector<StageProgress> progress_;
};

class JobRunner {
 public:
  // `threads` = arena concurrency; 0 = hardware concurrency.
  JobRunner(int threads, int max_concurrent_jobs);

  // A held job slot; released on destruction.
  class Slot {
   public:
    explicit Slot(std::atomic<int>* active) : active_(active) {}
    Slot(Slot&& o) noexcept : active_(std::exchange(o.active_, nullptr)) {}
    Slot& operator=(Slot&&) = delete;
    ~Slot() {
      if (active_ != nullptr) active_->fetch_sub(1);
    }

   private:
    std::atomic<int>* active_;
  };

  // A slot for one call, or RESOURCE_EXHAUSTED naming the limit when all are taken.
  absl::StatusOr<Slot> Acquire();
  std::shared_ptr<RunningJob> Start(PointCloud cloud, PipelineOptions options);

  int threads() const { return threads_; }
  int max_concurrent_jobs() const { return max_concurrent_jobs_; }

 private:
  int threads_;
  int max_concurrent_jobs_;
  std::atomic<int> active_{0};
  // TBB caps its workers at hardware concurrency - 1 by default (the rest is kept for a master
  // thread); every job here is enqueued, so the arena needs all `threads` as workers.
  tbb::global_control workers_;
  tbb::task_arena arena_;
};

}  // namespace scanprep::server
