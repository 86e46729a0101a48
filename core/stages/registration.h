// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/health_report.h"
#include "core/stages/param_table.h"
#include "core/stages/registration_report.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
struct HealthSettings;  // health.h: how pairs are found and judged

// Fine registration of overlapping scans (docs/health.md, Registration): point-to-plane ICP on
// the shared k-NN graph, every scan against all the others at once, moving each only along the
// directions its overlaps constrain, and by at most registration.max_correction spacings.
StageInfo RegistrationStageInfo();

// The parameters (RegistrationParams() declares them).
struct RegistrationSettings {
  int max_iterations = 0;     // steps at most
  double max_correction = 0;  // spacings: a scan that needs more is left where it was
  double tolerance = 0;       // spacings: a step this small on every scan ends the iterations
  // The share of a pair's residual spread its component's standard error may reach for a scan
  // to move along it.
  double max_standard_error = 0;
};
const ParamTable<RegistrationSettings>& RegistrationParams();

struct Registration {
  // Every overlapping pair as health measures it, before the first step.
  std::vector<PairHealth> pairs_before;
  // One per scan that overlaps another enough to be measured, in scan order.
  std::vector<ScanRegistration> scans;
};

// The stage: moves the points, normals and poses of every scan but each group's reference, and
// tells `nb` they moved. `pairs`: how pairs are found and which components are constrained
// (health's parameters, so health and registration agree on what the overlap sees).
absl::StatusOr<Registration> RegisterScans(PointCloud& cloud, const PointMeasures& m,
                                           Neighbourhoods& nb, const HealthSettings& pairs,
                                           const RegistrationSettings& settings,
                                           StageReporter& out);
}  // namespace scanprep
