// SPDX-License-Identifier: Apache-2.0
#include "server/job/job_runner.h"

#include <algorithm>
#include <new>
#include <thread>

#include "absl/strings/str_cat.h"
#include "core/base/happens_before.h"

namespace scanprep::server {

bool RunningJob::WaitFor(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mu_);
  return done_cv_.wait_for(lock, timeout, [&] { return result_.has_value(); });
}

std::vector<StageProgress> RunningJob::DrainProgress() {
  std::lock_guard lock(mu_);
  return std::exchange(progress_, {});
}

void RunningJob::End(absl::Status why) {
  {
    std::lock_guard lock(mu_);
    if (ended_.ok()) ended_ = std::move(why);
  }
  cancel_.Cancel();
}

bool RunningJob::done() const {
  std::lock_guard lock(mu_);
  return result_.has_value();
}

void RunningJob::OnProgress(const ProgressEvent& e) {
  if (hook_) hook_(e.stage, e.stage_fraction);
  const StageProgress p{.stage = std::string(e.stage),
                        .fraction = e.stage_fraction,
                        .stage_index = static_cast<uint32_t>(e.stage_index),
                        .stage_count = static_cast<uint32_t>(e.stage_count),
                        .job_fraction = e.job_fraction};
  std::lock_guard lock(mu_);
  if (!progress_.empty() && progress_.back().stage == p.stage) {
    progress_.back() = p;
  } else {
    progress_.push_back(p);
  }
}

void RunningJob::Run() {
  absl::StatusOr<PipelineReport> result;
  try {
    result =
        RunPipeline(cloud_, options_, cancel_, [this](const ProgressEvent& e) { OnProgress(e); });
  } catch (const std::bad_alloc&) {
    result = absl::ResourceExhaustedError("the server ran out of memory processing this job");
  } catch (const std::exception& e) {
    result = absl::InternalError(absl::StrCat("processing failed: ", e.what()));
  }
  std::lock_guard lock(mu_);
  if (!result.ok() && !ended_.ok()) result = ended_;
  result_ = std::move(result);
  done_cv_.notify_all();
}

JobRunner::JobRunner(int threads, ProgressHook hook)
    : threads_(threads > 0 ? threads
                           : std::max(1, static_cast<int>(std::thread::hardware_concurrency()))),
      hook_(std::move(hook)),
      workers_(tbb::global_control::max_allowed_parallelism, threads_ + 1),
      // No slot reserved for an external thread: every job is enqueued, none is executed.
      arena_(threads_, 0) {}

std::shared_ptr<RunningJob> JobRunner::Start(PointCloud cloud, PipelineOptions options,
                                             uint64_t reservation_bytes) {
  auto job =
      std::make_shared<RunningJob>(std::move(cloud), std::move(options), hook_, reservation_bytes);
  {
    std::lock_guard lock(mu_);
    std::erase_if(jobs_, [](const std::weak_ptr<RunningJob>& j) { return j.expired(); });
    jobs_.push_back(job);
    if (cancelled_all_) job->Cancel();
  }
  HappensBefore(job.get());  // TBB's queue orders this, but TSan cannot see inside libtbb
  arena_.enqueue([job] {
    HappensAfter(job.get());
    job->Run();
  });
  return job;
}

std::vector<std::shared_ptr<RunningJob>> JobRunner::Processing() const {
  std::vector<std::shared_ptr<RunningJob>> processing;
  std::lock_guard lock(mu_);
  for (const std::weak_ptr<RunningJob>& j : jobs_) {
    if (auto job = j.lock(); job != nullptr && !job->done()) processing.push_back(std::move(job));
  }
  return processing;
}

void JobRunner::CancelAll() {
  std::lock_guard lock(mu_);
  cancelled_all_ = true;
  for (const std::weak_ptr<RunningJob>& j : jobs_) {
    if (auto job = j.lock()) job->Cancel();
  }
}

bool JobRunner::cancelled_all() const {
  std::lock_guard lock(mu_);
  return cancelled_all_;
}

}  // namespace scanprep::server
