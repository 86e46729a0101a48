// SPDX-License-Identifier: Apache-2.0
// The health report (issue 32) as tables for people: one row per scan (noise, shares, viewing
// angle), one per overlapping pair (residual, misalignment, what the overlap cannot constrain).
// Printed by `scanprep health` and `scanprep process --health`.
#pragma once

#include <ostream>

#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::client {

// Lengths of a pair in µm (a calibration drifts by micrometres), the scans' noise in mm as the
// report states it, shares in %; a value the report leaves unset is "-", and so is a misalignment
// component the overlap cannot constrain (the server sends it as 0, which would read as "no
// misalignment"). A report without health (the stage did not run) says so in one line. After the
// pairs, when the job ran registration: one row per registered scan (its role, the motion applied
// in µm and degrees, the directions it moved along, its residual before and after in µm, steps).
void PrintHealth(std::ostream& out, const scanprep::v1::Report& report);

}  // namespace scanprep::client
