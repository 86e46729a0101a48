// SPDX-License-Identifier: Apache-2.0
// Is the job's unit right? Judged from the data: a scan's measured point spacing against the
// spacing it states, and its measured noise σ̂ against its stated uncertainty u. A file in metres
// sent as millimetres has both about 1000x smaller than stated (inches as mm: 25.4x larger).
#pragma once

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {

// Measured and stated scales further apart than this factor (either way) point to a unit slip:
// below inch↔mm (25.4) and far below m↔mm and µm↔mm (1000), above what an honest datasheet and
// a real surface differ by (oblique views widen spacing, a 3σ figure read as 1σ is 3x).
inline constexpr double kUnitSuspectFactor = 20;

// Warns UNIT_SUSPECT for each scan whose every stated scale that can be checked (a stated
// scanline or point spacing; a stated u when σ̂ is measured) disagrees with the data by more than
// kUnitSuspectFactor in the same direction. A scan that states nothing is not judged: one
// UNIT_UNCHECKED names such scans and what they could state (strict fails on it). Needs the
// neighbourhoods and `m`'s normal fits (run at the end of the normals stage). CANCELLED
// when the job's token fires.
absl::Status WarnIfUnitSuspect(const PointCloud& cloud, const PointMeasures& m,
                               const Neighbourhoods& nb, StageReporter& out);

}  // namespace scanprep
