// SPDX-License-Identifier: Apache-2.0
#include "core/stages/unit_plausibility.h"

#include <algorithm>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
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

}  // namespace

absl::Status WarnIfUnitSuspect(const PointCloud& cloud, const PointMeasures& m,
                               const Neighbourhoods& nb, StageReporter& out) {
  if (nb.k() == 0) return absl::OkStatus();
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> spacing,
                            MedianNearestDistance(cloud, nb, out.cancel()));
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<std::optional<double>> noise,
                            MeasuredScanNoise(cloud, m, cloud.scans.size(), out.cancel()));
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
    if (verdicts.empty() || verdicts.front() == 0 ||
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
  return absl::OkStatus();
}

}  // namespace scanprep
