// SPDX-License-Identifier: Apache-2.0
#include "core/stages/unit_plausibility.h"

#include <algorithm>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/spatial/median_nearest.h"
#include "core/stages/scan_noise.h"

namespace scanprep {
namespace {

// The smallest spacing the scan states (nearest neighbours lie along the finer direction), or
// nothing when it states none.
std::optional<double> StatedSpacing(const ScanMeta& scan) {
  std::optional<double> stated;
  for (const double s : {scan.scanline_spacing, scan.point_spacing}) {
    if (s > 0) stated = std::min(stated.value_or(s), s);
  }
  return stated;
}

// -1: the data is more than kUnitSuspectFactor smaller than stated, +1 larger, 0 plausible.
int Disagreement(double measured, double stated) {
  if (measured * kUnitSuspectFactor < stated) return -1;
  if (measured > kUnitSuspectFactor * stated) return +1;
  return 0;
}

// UNIT_UNCHECKED, once for the job: which scans' unit nothing could confirm, and what to state.
void WarnUnitUnchecked(const PointCloud& cloud, const std::vector<size_t>& unchecked,
                       StageReporter& out) {
  std::vector<std::string> named;
  for (size_t i = 0; i < std::min<size_t>(unchecked.size(), 5); ++i) {
    named.push_back(absl::StrCat("'", cloud.scans[unchecked[i]].id, "'"));
  }
  const std::string first = absl::StrJoin(named, ", ");
  out.Warn(WarningCode::kUnitUnchecked,
           absl::StrCat("the unit of ", unchecked.size(), " of ", cloud.scans.size(),
                        " scans could not be checked (", first,
                        unchecked.size() > named.size() ? ", …" : "",
                        "): a scan states no scanline_spacing or point_spacing, or an uncertainty "
                        "whose noise could be measured, to compare its data with; state one for "
                        "the job's unit to be judged"),
           {{"scans_unchecked", absl::StrCat(unchecked.size())},
            {"scans", absl::StrCat(cloud.scans.size())},
            {"first_scans", first},
            {"state_one_of", "scanline_spacing, point_spacing, uncertainty"}});
}

}  // namespace

absl::Status WarnIfUnitSuspect(const PointCloud& cloud, const PointMeasures& m,
                               const Neighbourhoods& nb, StageReporter& out) {
  if (nb.k() == 0) return absl::OkStatus();
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing,
                            MedianNearestDistance(cloud, nb, out.cancel()));
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<std::optional<double>> noise,
                            MeasuredScanNoise(cloud, m, cloud.scans.size(), out.cancel()));
  std::vector<size_t> unchecked;  // scans no stated scale could be compared with
  for (size_t s = 0; s < cloud.scans.size(); ++s) {
    const ScanMeta& scan = cloud.scans[s];
    std::vector<int> verdicts;
    std::map<std::string, std::string> params{{"scan", scan.id}};
    std::string evidence;
    if (const std::optional<double> stated = StatedSpacing(scan); stated && spacing[s] > 0) {
      verdicts.push_back(Disagreement(spacing[s], *stated));
      params["measured_spacing_mm"] = absl::StrCat(spacing[s]);
      params["stated_spacing_mm"] = absl::StrCat(*stated);
      absl::StrAppend(&evidence, "its points lie ", spacing[s], " mm apart against a stated ",
                      *stated, " mm");
    }
    if (scan.uncertainty_stated && noise[s]) {
      verdicts.push_back(Disagreement(*noise[s], scan.uncertainty));
      params["measured_noise_mm"] = absl::StrCat(*noise[s]);
      params["stated_uncertainty_mm"] = absl::StrCat(scan.uncertainty);
      absl::StrAppend(&evidence, evidence.empty() ? "its" : "; its", " noise σ̂ = ", *noise[s],
                      " mm against a stated u = ", scan.uncertainty, " mm");
    }
    if (verdicts.empty()) {
      unchecked.push_back(s);
      continue;
    }
    if (verdicts.front() == 0 ||
        std::any_of(verdicts.begin(), verdicts.end(), [&](int v) { return v != verdicts[0]; })) {
      continue;
    }
    out.Warn(WarningCode::kUnitSuspect,
             absl::StrCat("scan '", scan.id, "': ", evidence, ", more than ", kUnitSuspectFactor,
                          "x ", verdicts.front() < 0 ? "smaller" : "larger",
                          " than stated: is the job's unit right (a file in metres sent as "
                          "millimetres is 1000x smaller)?"),
             std::move(params));
  }
  if (!unchecked.empty()) WarnUnitUnchecked(cloud, unchecked, out);
  return absl::OkStatus();
}

}  // namespace scanprep
