// SPDX-License-Identifier: Apache-2.0
// A warning a program can act on: a stable code (its name never changes once released; the
// gRPC API's WarningCode carries the same names with the WARNING_CODE_ prefix), the text for
// people, and the numbers behind it as named parameters. A job can be told to fail on codes
// (PipelineOptions::fail_on): it then ends FAILED_PRECONDITION at the end of the stage that
// raised one, so no later stage works on a result the caller has already refused.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"

namespace scanprep {

// Every code, declared once: X(enumerator, stable name). docs/api.md explains each.
#define SCANPREP_WARNING_CODES(X)                                           \
  X(kUnitSuspect, "UNIT_SUSPECT")                                           \
  X(kNoPose, "NO_POSE")                                                     \
  X(kBallsCapped, "BALLS_CAPPED")                                           \
  X(kSingleScanNoMerge, "SINGLE_SCAN_NO_MERGE")                             \
  X(kRadiusCapped, "RADIUS_CAPPED")                                         \
  X(kUniformQualityNoMerge, "UNIFORM_QUALITY_NO_MERGE")                     \
  X(kSmoothingWithoutQuality, "SMOOTHING_WITHOUT_QUALITY")                  \
  X(kNoiseUnmeasured, "NOISE_UNMEASURED")                                   \
  X(kNoiseAboveUncertainty, "NOISE_ABOVE_UNCERTAINTY")                      \
  X(kNoUncertainty, "NO_UNCERTAINTY")                                       \
  X(kToleranceFromDefaultUncertainty, "TOLERANCE_FROM_DEFAULT_UNCERTAINTY") \
  X(kNoScanlineSpacing, "NO_SCANLINE_SPACING")                              \
  X(kDuplicatesCollapsed, "DUPLICATES_COLLAPSED")                           \
  X(kNoScanlines, "NO_SCANLINES")                                           \
  X(kWindowsCapped, "WINDOWS_CAPPED")                                       \
  X(kOutliersKReduced, "OUTLIERS_K_REDUCED")                                \
  X(kSurfaceSpikesSkipped, "SURFACE_SPIKES_SKIPPED")                        \
  X(kNormalsPropagated, "NORMALS_PROPAGATED")                               \
  X(kSpacingFromDensity, "SPACING_FROM_DENSITY")                            \
  X(kScanRepeated, "SCAN_REPEATED")                                         \
  X(kPointsInvalid, "POINTS_INVALID")                                       \
  X(kUnitUnchecked, "UNIT_UNCHECKED")                                       \
  X(kScanlinesImplausible, "SCANLINES_IMPLAUSIBLE")                         \
  X(kRegistrationBoundExceeded, "REGISTRATION_BOUND_EXCEEDED")

enum class WarningCode {
#define SCANPREP_WARNING_ENUMERATOR(code, name) code,
  SCANPREP_WARNING_CODES(SCANPREP_WARNING_ENUMERATOR)
#undef SCANPREP_WARNING_ENUMERATOR
};

struct Warning {
  WarningCode code;
  std::string message;
  std::map<std::string, std::string> params;  // the numbers behind it, e.g. "stated_mm"
};

// Every code, in declaration order.
std::span<const WarningCode> AllWarningCodes();
// The stable name, e.g. "UNIT_SUSPECT".
std::string_view WarningCodeName(WarningCode code);
std::optional<WarningCode> WarningCodeFromName(std::string_view name);

// The codes `scanprep process --strict` fails on: those that say the request is probably wrong
// (its unit, its stated u, a scan sent twice, points it could not use) or could not be checked
// (a unit no stated scale can confirm), so its result should not be used. Left out: codes that
// describe a correct job's circumstances (one scan, no poses, no stated u), and the caps
// (RADIUS_CAPPED, BALLS_CAPPED, WINDOWS_CAPPED), which are symptoms: their usual cause, a unit
// slip, is named by UNIT_SUSPECT at the end of the normals stage, and failing on the symptom first
// (neighbourhoods) would hide the cause.
std::span<const WarningCode> StrictWarningCodes();

// FAILED_PRECONDITION "<message> (fail_on <CODE>)" for the first of `warnings` whose code is in
// `fail_on`, carrying the code and the message as payloads (FailedWarning); OK when none is.
absl::Status FailOnWarnings(std::span<const Warning> warnings,
                            const std::set<WarningCode>& fail_on);

// Warnings of one code the report keeps: a job of 1,000 scans raised three per scan (3,005 in
// all, 1.9 MB of report with their 256-byte scan ids, twice: as text and as details).
inline constexpr size_t kMaxWarningsPerCode = 10;

// Keeps the first kMaxWarningsPerCode warnings of each code, in order, and folds the rest of a
// code into one more of that code that says how many were left out (param `warnings_left_out`)
// and quotes the first of them, so the report's size does not grow with the scans.
void FoldRepeatedWarnings(std::vector<Warning>& warnings);

// The warning a FailOnWarnings status failed on; nothing for any other status.
std::optional<Warning> FailedWarning(const absl::Status& status);

}  // namespace scanprep
