// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/pipeline_runner.h"

#include <algorithm>
#include <chrono>
#include <span>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace scanprep {

PipelineRunner::PipelineRunner(const Plan& plan, PointCloud& cloud, const CancelToken& cancel,
                               ProgressFn progress, std::set<WarningCode> fail_on,
                               const DuplicateGroups* duplicates)
    : plan_(plan),
      cloud_(cloud),
      cancel_(cancel, *this),
      progress_(std::move(progress)),
      fail_on_(std::move(fail_on)) {
  shared_.duplicates = duplicates;
  for (const StageInfo* stage : plan_.stages()) plan_weight_ += stage->cost_weight;
}

absl::Status PipelineRunner::Run() {
  while (next_ < plan_.stages().size()) SCANPREP_RETURN_IF_ERROR(RunStage(next_++));
  return absl::OkStatus();
}

absl::Status PipelineRunner::RunThrough(std::string_view stage) {
  const auto& stages = plan_.stages();
  const auto it = std::find_if(stages.begin() + next_, stages.end(),
                               [&](const StageInfo* s) { return s->name == stage; });
  if (it == stages.end()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "stage '", std::string(stage), "' is not among the plan's stages still to run"));
  }
  const size_t end = static_cast<size_t>(it - stages.begin()) + 1;
  while (next_ < end) SCANPREP_RETURN_IF_ERROR(RunStage(next_++));
  return absl::OkStatus();
}

// A stage's loops take it to at most this fraction: its end says 1.
constexpr double kLoopCeiling = 0.99;

void PipelineRunner::Worked(size_t items) {
  const uint64_t done = meter_.done.fetch_add(items, std::memory_order_relaxed) + items;
  Emit(std::min(kLoopCeiling, static_cast<double>(done) / meter_.expected));
}

void PipelineRunner::Progress(double fraction) { Emit(std::clamp(fraction, 0.0, 1.0)); }

void PipelineRunner::ExpectWork(double items) { meter_.expected = std::max(1.0, items); }

void PipelineRunner::Emit(double stage_fraction) {
  if (!progress_) return;
  const int tick = static_cast<int>(stage_fraction * 50);
  if (tick <= meter_.tick.load(std::memory_order_relaxed)) return;
  std::lock_guard lock(progress_mu_);
  if (tick <= meter_.tick.load(std::memory_order_relaxed)) return;
  meter_.tick.store(tick, std::memory_order_relaxed);
  const StageInfo& running = *plan_.stages()[index_];
  if (plan_weight_ > 0) {
    job_fraction_ = std::max(
        job_fraction_,
        std::min(1.0, (done_weight_ + running.cost_weight * stage_fraction) / plan_weight_));
  }
  progress_({.stage = running.name,
             .stage_index = index_,
             .stage_count = plan_.stages().size(),
             .stage_fraction = stage_fraction,
             .job_fraction = job_fraction_});
}

// Capped balls above this share of the points get a warning (they are always recorded).
constexpr double kCappedBallsWarnShare = 0.01;

void PipelineRunner::RecordBallCounts(StageReport& stage) {
  const Neighbourhoods* nb = shared_.neighbourhoods.get();
  if (nb == nullptr) return;
  // Since the last stage that ended: each stage claims the balls it capped and sampled.
  const uint64_t capped = nb->capped_balls() - capped_reported_;
  const uint64_t cut = nb->capped_points() - cut_reported_;
  const uint64_t sampled = nb->sampled_balls() - sampled_reported_;
  capped_reported_ += capped;
  cut_reported_ += cut;
  sampled_reported_ += sampled;
  if (sampled > 0) {
    stage.parameters[absl::StrCat(stage.name, ".balls_sampled")] = static_cast<double>(sampled);
  }
  if (capped == 0) return;
  stage.parameters[absl::StrCat(stage.name, ".balls_capped")] = static_cast<double>(capped);
  stage.parameters[absl::StrCat(stage.name, ".ball_points_left_out")] = static_cast<double>(cut);
  // A spike far off a dense surface has a k-th neighbour far away, and its ball is capped as a
  // matter of course; only when many are does the job's scale look wrong.
  if (static_cast<double>(capped) < kCappedBallsWarnShare * static_cast<double>(cloud_.size())) {
    return;
  }
  report_.warnings.push_back(
      {WarningCode::kBallsCapped,
       absl::StrCat(stage.name, ": ", capped, " neighbourhoods held more than ",
                    nb->max_ball_points(), " points and kept their nearest ", nb->max_ball_points(),
                    " (", cut,
                    " or more points left out); many "
                    "point to a radius far beyond the data's spacing: check the job's unit and "
                    "radius overrides"),
       {{"balls_capped", absl::StrCat(capped)}, {"points_left_out", absl::StrCat(cut)}}});
}

uint64_t PipelineRunner::KeptInputPoints() const {
  const DuplicateGroups* duplicates = shared_.duplicates;
  if (duplicates == nullptr || duplicates->collapsed() == 0) return cloud_.CountKept();
  uint64_t kept = 0;
  for (size_t g = 0; g < cloud_.size(); ++g) {
    if (!cloud_.removed(g)) kept += duplicates->multiplicity[g];
  }
  return kept;
}

absl::Status PipelineRunner::RunStage(size_t index) {
  SCANPREP_RETURN_IF_ERROR(cancel_.Check());
  const StageInfo& info = *plan_.stages()[index];
  index_ = index;
  StageReport& stage = report_.stages.emplace_back(StageReport{.name = info.name});
  stage.points_in = KeptInputPoints();
  meter_.done.store(0, std::memory_order_relaxed);
  meter_.tick.store(-1, std::memory_order_relaxed);
  ExpectWork(info.work_per_point * static_cast<double>(cloud_.size()));
  Emit(0.0);

  const size_t first_warning = report_.warnings.size();
  const auto start = std::chrono::steady_clock::now();
  StageContext ctx(cloud_, shared_, plan_.params(), cancel_, *this, stage, report_.warnings);
  absl::Status status = info.make()->Run(ctx);
  RecordBallCounts(stage);
  if (status.ok()) {
    status = FailOnWarnings(std::span(report_.warnings).subspan(first_warning), fail_on_);
  }
  stage.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stage.points_out = KeptInputPoints();
  if (status.ok()) {
    Emit(1.0);
    done_weight_ += info.cost_weight;
    shared_.stages_run.push_back(info.name);
    if (shared_.health) report_.health = *std::exchange(shared_.health, std::nullopt);
    if (!shared_.registration.empty())
      report_.registration = std::exchange(shared_.registration, {});
  }
  return status;
}

}  // namespace scanprep
