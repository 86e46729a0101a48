// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/job_context.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/status_macros.h"

namespace scanprep {

JobContext::JobContext(PointCloud& cloud, const ParamOverrides& overrides,
                       const CancelToken& cancel, ProgressFn progress)
    : cloud_(cloud),
      overrides_(overrides),
      cancel_(cancel, *this),
      progress_(std::move(progress)) {}

std::optional<double> JobContext::Overridden(std::string_view name) const {
  auto it = overrides_.find(name);
  double value = 0;
  // Validated before the job started (ValidateOverrides), so the parse succeeds.
  if (it == overrides_.end() || !absl::SimpleAtod(it->second, &value)) return std::nullopt;
  return value;
}

double JobContext::Number(std::string_view name) {
  const ParamSpec& spec = DeclaredSpec(name, ParamKind::kReal, /*derived=*/false);
  return Recorded(name, Overridden(name).value_or(*spec.default_value));
}

double JobContext::Number(std::string_view name, double derived) {
  DeclaredSpec(name, ParamKind::kReal, /*derived=*/true);
  return Recorded(name, Overridden(name).value_or(derived));
}

int64_t JobContext::Integer(std::string_view name) {
  const ParamSpec& spec = DeclaredSpec(name, ParamKind::kInteger, /*derived=*/false);
  // In range, so well inside int64_t: the conversion is exact.
  return static_cast<int64_t>(Recorded(name, Overridden(name).value_or(*spec.default_value)));
}

int64_t JobContext::Integer(std::string_view name, int64_t derived) {
  DeclaredSpec(name, ParamKind::kInteger, /*derived=*/true);
  const double value = Overridden(name).value_or(static_cast<double>(derived));
  return static_cast<int64_t>(Recorded(name, value));
}

std::string JobContext::Choice(std::string_view name) {
  const ParamSpec& spec = DeclaredSpec(name, ParamKind::kChoice, /*derived=*/false);
  auto it = overrides_.find(name);
  std::string value = it != overrides_.end() ? it->second : spec.choices.front();
  current().text_parameters[std::string(name)] = value;
  return value;
}

// A stage reading a parameter it did not declare, or with the wrong kind of default, is a
// programming error that no request can cause; the parameter sweep test reads every one.
const ParamSpec& JobContext::DeclaredSpec(std::string_view name, ParamKind kind, bool derived) {
  const ParamSpec* spec = FindParam(name);
  if (spec == nullptr || spec->kind != kind ||
      (kind != ParamKind::kChoice && spec->default_value.has_value() == derived)) {
    std::fprintf(stderr, "scanprep: parameter %.*s is read against its declaration\n",
                 static_cast<int>(name.size()), name.data());
    std::abort();
  }
  return *spec;
}

void JobContext::Record(std::string_view name, double value) {
  current().parameters[std::string(name)] = value;
}

double JobContext::CapRadius(std::string_view what, double radius, double limit) {
  if (!(radius > limit)) return radius;
  const std::string& stage = current().name;
  // One warning per stage (a job of 1,000 scans would otherwise say it 1,000 times); the
  // counter has them all.
  if (current().parameters[absl::StrCat(stage, ".radii_capped")]++ > 0) return limit;
  Warn(WarningCode::kRadiusCapped,
       absl::StrFormat("%s: %s of %g mm is more than the data's own scale allows (%g mm, a "
                       "multiple of the global radius r_g); capped at %g mm. Check the job's "
                       "unit, the scanner metadata (spacing, uncertainty) and radius overrides",
                       stage, what, radius, limit, limit),
       {{"radius_mm", absl::StrCat(radius)}, {"limit_mm", absl::StrCat(limit)}});
  return limit;
}

uint64_t JobContext::KeptInputPoints() const {
  if (duplicates_collapsed() == 0) return cloud_.CountKept();
  uint64_t kept = 0;
  for (size_t g = 0; g < cloud_.size(); ++g) {
    if (!cloud_.removed(g)) kept += duplicates_->multiplicity[g];
  }
  return kept;
}

void JobContext::RecordForScan(std::string_view name, size_t scan, double value) {
  const std::string base(name);
  Record(cloud_.scans.size() > 1 ? absl::StrCat(base, ".scan", scan) : base, value);
}

double JobContext::Recorded(std::string_view name, double value) {
  Record(name, value);
  return value;
}

void JobContext::Warn(WarningCode code, std::string message,
                      std::map<std::string, std::string> params) {
  report_.warnings.push_back({code, std::move(message), std::move(params)});
}

double JobContext::PlannedNumber(std::string_view name) const {
  const ParamSpec* spec = FindParam(name);
  return Overridden(name).value_or(spec->default_value.value_or(0));
}

std::string JobContext::PlannedChoice(std::string_view name) const {
  auto it = overrides_.find(name);
  return it != overrides_.end() ? it->second : FindParam(name)->choices.front();
}

std::vector<const StageInfo*> JobContext::Order(const std::vector<std::string>& requested) const {
  std::vector<const StageInfo*> order;
  // Depth-first: a stage's prerequisites (theirs first) before it. Prerequisites only name stages
  // whose own ones lead back to neighbourhoods, never to the asking stage (Progress tests check
  // every stage), so the recursion ends.
  std::function<void(const StageInfo&)> add = [&](const StageInfo& info) {
    if (std::find(order.begin(), order.end(), &info) != order.end()) return;
    if (info.prerequisites) {
      for (const std::string& name : info.prerequisites(*this)) add(*FindStage(name));
    }
    order.push_back(&info);
  };
  for (const std::string& name : requested) add(*FindStage(name));
  return order;
}

std::vector<const StageInfo*> JobContext::Plan(const std::vector<std::string>& requested) {
  plan_ = Order(requested);
  plan_weight_ = 0;
  for (const StageInfo* info : plan_) plan_weight_ += info->cost_weight;
  done_weight_ = 0;
  return plan_;
}

// A stage's loops take it to at most this fraction: its end says 1.
constexpr double kLoopCeiling = 0.99;

void JobContext::Worked(size_t items) {
  const uint64_t done = meter_.done.fetch_add(items, std::memory_order_relaxed) + items;
  Emit(std::min(kLoopCeiling, static_cast<double>(done) / meter_.expected));
}

void JobContext::Progress(double fraction) { Emit(std::clamp(fraction, 0.0, 1.0)); }

void JobContext::ExpectWork(double items) { meter_.expected = std::max(1.0, items); }

void JobContext::Emit(double stage_fraction) {
  if (!progress_) return;
  const int step = static_cast<int>(stage_fraction * 50);
  if (step <= meter_.step.load(std::memory_order_relaxed)) return;
  std::lock_guard lock(progress_mu_);
  if (step <= meter_.step.load(std::memory_order_relaxed)) return;
  meter_.step.store(step, std::memory_order_relaxed);
  const std::string& stage = report_.stages[current_stage_].name;
  const bool planned = plan_index_ < plan_.size() && plan_[plan_index_]->name == stage;
  if (plan_weight_ > 0) {
    const double running = planned ? plan_[plan_index_]->cost_weight * stage_fraction : 0;
    job_fraction_ = std::max(job_fraction_, std::min(1.0, (done_weight_ + running) / plan_weight_));
  }
  progress_({.stage = stage,
             .stage_index = plan_index_,
             .stage_count = plan_.size(),
             .stage_fraction = stage_fraction,
             .job_fraction = job_fraction_});
}

absl::StatusOr<const Neighbourhoods*> JobContext::neighbourhoods() {
  if (!neighbourhoods_) {
    const StageInfo* info = FindStage("neighbourhoods");
    SCANPREP_RETURN_IF_ERROR(RunStage(*info));
  }
  return neighbourhoods_.get();
}

absl::Status JobContext::PointsMoved(float max_shift) {
  if (!neighbourhoods_) return absl::OkStatus();
  return neighbourhoods_->PointsMoved(cloud_, max_shift, cancel_);
}

bool JobContext::HasRun(std::string_view stage) const {
  // The neighbourhoods are built once and then follow the cloud (PointsMoved, removals).
  if (stage == "neighbourhoods") return neighbourhoods_ != nullptr;
  return std::find(completed_.begin(), completed_.end(), stage) != completed_.end();
}

absl::Status JobContext::Require(std::string_view stage) {
  const StageInfo* info = FindStage(stage);
  if (info == nullptr)
    return absl::InternalError(absl::StrCat("no stage named ", std::string(stage)));
  for (const StageInfo* step : Order({info->name})) {
    if (!HasRun(step->name)) SCANPREP_RETURN_IF_ERROR(RunStage(*step));
  }
  return absl::OkStatus();
}

// Capped balls above this share of the points get a warning (they are always recorded).
constexpr double kCappedBallsWarnShare = 0.01;

void JobContext::RecordCappedBalls(const std::string& stage) {
  if (!neighbourhoods_) return;
  // Since the last stage that ended: a stage nested in another claims the balls it capped.
  const uint64_t capped = neighbourhoods_->capped_balls() - capped_reported_;
  const uint64_t cut = neighbourhoods_->capped_points() - cut_reported_;
  capped_reported_ += capped;
  cut_reported_ += cut;
  if (capped == 0) return;
  Record(absl::StrCat(stage, ".balls_capped"), static_cast<double>(capped));
  Record(absl::StrCat(stage, ".ball_points_left_out"), static_cast<double>(cut));
  // A spike far off a dense surface has a k-th neighbour far away, and its ball is capped as a
  // matter of course; only when many are does the job's scale look wrong.
  if (static_cast<double>(capped) < kCappedBallsWarnShare * static_cast<double>(cloud_.size())) {
    return;
  }
  Warn(WarningCode::kBallsCapped,
       absl::StrCat(stage, ": ", capped, " neighbourhoods held more than ",
                    neighbourhoods_->max_ball_points(), " points and kept their nearest ",
                    neighbourhoods_->max_ball_points(), " (", cut,
                    " or more points left out); many "
                    "point to a radius far beyond the data's spacing: check the job's unit and "
                    "radius overrides"),
       {{"balls_capped", absl::StrCat(capped)}, {"points_left_out", absl::StrCat(cut)}});
}

absl::Status JobContext::RunStage(const StageInfo& info) {
  SCANPREP_RETURN_IF_ERROR(cancel_.Check());
  // A stage pulled in by Require() while another runs is listed before it, as it ran first in
  // effect, and the caller's time excludes it.
  const bool nested = running_;
  const size_t slot = nested ? current_stage_ : report_.stages.size();
  report_.stages.insert(report_.stages.begin() + slot, StageReport{.name = info.name});
  current_stage_ = slot;
  report_.stages[slot].points_in = KeptInputPoints();
  // A nested stage meters its own work; the outer one's count resumes after it.
  const uint64_t outer_done = meter_.done.load(std::memory_order_relaxed);
  const double outer_expected = meter_.expected;
  const int outer_step = meter_.step.load(std::memory_order_relaxed);
  const size_t outer_index = plan_index_;
  for (size_t i = 0; i < plan_.size(); ++i) {
    if (plan_[i]->name == info.name) plan_index_ = i;
  }
  meter_.done.store(0, std::memory_order_relaxed);
  meter_.step.store(-1, std::memory_order_relaxed);
  ExpectWork(info.work_per_point * static_cast<double>(cloud_.size()));
  Emit(0.0);

  running_ = true;
  const size_t first_warning = report_.warnings.size();
  const auto start = std::chrono::steady_clock::now();
  absl::Status status = info.make()->Run(*this);
  RecordCappedBalls(info.name);
  if (status.ok()) {
    status = FailOnWarnings(std::span(report_.warnings).subspan(first_warning), fail_on_);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  running_ = nested;

  // Stages nested in this one moved it down the list by one slot each.
  StageReport& done = report_.stages[current_stage_];
  done.seconds += seconds;
  done.points_out = KeptInputPoints();
  if (nested) report_.stages[current_stage_ + 1].seconds -= seconds;
  if (status.ok()) {
    Emit(1.0);
    if (info.name != "neighbourhoods") completed_.push_back(info.name);
    if (plan_index_ < plan_.size() && plan_[plan_index_]->name == info.name) {
      done_weight_ += info.cost_weight;
    }
  }
  if (nested) {
    meter_.done.store(outer_done, std::memory_order_relaxed);
    meter_.expected = outer_expected;
    meter_.step.store(outer_step, std::memory_order_relaxed);
    plan_index_ = outer_index;
  }
  if (nested) ++current_stage_;
  return status;
}

}  // namespace scanprep
