// SPDX-License-Identifier: Apache-2.0
#include "client/health_table.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace scanprep::client {
namespace {

namespace v1 = ::scanprep::v1;

constexpr char kUnset[] = "-";

// Headers and cells are ASCII ("um", "deg", "noise/u"): absl::StrFormat pads by bytes, so a µ or
// σ̂ would shift every column after it.
std::string Share(bool has, double share) {
  return has ? absl::StrFormat("%.2f", 100 * share) : kUnset;
}

std::string ViewingAngles(const v1::ScanHealth& scan) {
  if (scan.viewing_angle_percentiles_deg_size() != 3) return kUnset;
  return absl::StrFormat("%.0f/%.0f/%.0f", scan.viewing_angle_percentiles_deg(0),
                         scan.viewing_angle_percentiles_deg(1),
                         scan.viewing_angle_percentiles_deg(2));
}

// x, y, z of `v` as "x/y/z", each cell cell(axis, value).
template <typename Cell>
std::string Xyz(const v1::Vec3& v, Cell cell) {
  return absl::StrJoin({cell('x', v.x()), cell('y', v.y()), cell('z', v.z())}, "/");
}

// A misalignment vector (`prefix` "t" or "r" names the components), each to `decimals` after
// scaling by `scale`; a component the overlap cannot constrain is "-".
std::string Components(const v1::PairHealth& pair, char prefix, const v1::Vec3& v, double scale,
                       int decimals) {
  return Xyz(v, [&](char axis, double value) -> std::string {
    const std::string name = {prefix, axis};
    const bool free = std::find(pair.unconstrained().begin(), pair.unconstrained().end(), name) !=
                      pair.unconstrained().end();
    return free ? kUnset : absl::StrFormat("%.*f", decimals, scale * value);
  });
}

// Every component of `v` scaled by `scale` to `decimals`: a registration's motion, and the
// standard errors of a misalignment, unconstrained components included (they say why); "inf"
// where the overlap holds nothing along one.
std::string Scaled(const v1::Vec3& v, double scale, int decimals) {
  return Xyz(v, [&](char, double value) -> std::string {
    return std::isinf(value) ? "inf" : absl::StrFormat("%.*f", decimals, scale * value);
  });
}

// Wide enough for the longest scan id (file stems such as "happyStandRight_264"), at least 16.
int IdWidth(const v1::HealthReport& health) {
  size_t width = 16;
  for (const v1::ScanHealth& s : health.scans()) {
    width = std::max({width, s.scan_id().size(), s.sensor_id().size()});
  }
  return static_cast<int>(width);
}

void PrintScans(std::ostream& out, const v1::HealthReport& health) {
  const int w = IdWidth(health);
  out << absl::StrFormat("%-*s %-*s %9s %9s %8s %9s %8s %9s  %s\n", w, "scan", w, "sensor",
                         "points", "noise_mm", "noise/u", "outlier%", "merged%", "invalid%",
                         "view_deg p10/p50/p90");
  for (const v1::ScanHealth& s : health.scans()) {
    out << absl::StrFormat(
        "%-*s %-*s %9d %9s %8s %9s %8s %9s  %s\n", w, s.scan_id(), w,
        s.sensor_id().empty() ? kUnset : s.sensor_id(), s.points(),
        s.has_noise_mm() ? absl::StrFormat("%.4f", s.noise_mm()) : kUnset,
        s.has_noise_to_uncertainty() ? absl::StrFormat("%.2f", s.noise_to_uncertainty()) : kUnset,
        Share(s.has_outlier_share(), s.outlier_share()),
        Share(s.has_merged_share(), s.merged_share()), Share(true, s.invalid_share()),
        ViewingAngles(s));
  }
}

void PrintPairs(std::ostream& out, const v1::HealthReport& health) {
  const int w = IdWidth(health);
  out << absl::StrFormat("%-*s %-*s %9s %10s %10s  %-26s %-22s %-26s %-22s %s\n", w, "fixed", w,
                         "moving", "overlap", "median_um", "spread_um", "translation_um x/y/z",
                         "se_um x/y/z", "rotation_deg x/y/z", "se_deg x/y/z", "unconstrained");
  for (const v1::PairHealth& p : health.pairs()) {
    std::string free = absl::StrJoin(p.unconstrained(), ",");
    if (!p.note().empty()) free = absl::StrCat(free.empty() ? "" : free + " ", "(", p.note(), ")");
    out << absl::StrFormat(
        "%-*s %-*s %9d %10.2f %10.2f  %-26s %-22s %-26s %-22s %s\n", w, p.fixed_scan_id(), w,
        p.moving_scan_id(), p.overlap_points(), 1000 * p.residual_median_mm(),
        1000 * p.residual_spread_mm(), Components(p, 't', p.translation_mm(), 1000, 2),
        Scaled(p.translation_se_mm(), 1000, 2), Components(p, 'r', p.rotation_deg(), 1, 4),
        Scaled(p.rotation_se_deg(), 1, 4), free.empty() ? kUnset : free);
  }
}

// What registration did to the scan: held as its group's reference, put back (its correction
// exceeded the bound), moved, or left (no step kept).
std::string Role(const v1::ScanRegistration& scan) {
  if (scan.reference()) return "reference";
  if (scan.bound_exceeded()) return "put-back";
  return scan.iterations() > 0 ? "moved" : "left";
}

std::string Micrometres(bool has, double mm) {
  return has ? absl::StrFormat("%.2f", 1000 * mm) : kUnset;
}

// Its scans are the health report's, so the columns line up with its tables.
void PrintRegistration(std::ostream& out, const v1::Report& report) {
  const int w = IdWidth(report.health());
  out << absl::StrFormat("%-*s %-9s %-26s %-26s %10s %10s %9s %5s\n", w, "scan", "role",
                         "translation_um x/y/z", "rotation_deg x/y/z", "directions", "before_um",
                         "after_um", "steps");
  for (const v1::ScanRegistration& s : report.registration()) {
    out << absl::StrFormat(
        "%-*s %-9s %-26s %-26s %10d %10s %9s %5d\n", w, s.scan_id(), Role(s),
        Scaled(s.translation_mm(), 1000, 2), Scaled(s.rotation_deg(), 1, 4),
        s.constrained_directions(), Micrometres(s.has_residual_before_mm(), s.residual_before_mm()),
        Micrometres(s.has_residual_after_mm(), s.residual_after_mm()), s.iterations());
  }
}

}  // namespace

void PrintHealth(std::ostream& out, const v1::Report& report) {
  if (!report.has_health()) {
    out << "health: not measured (the job did not run the \"health\" stage)\n";
    return;
  }
  out << "health of the scans:\n";
  PrintScans(out, report.health());
  if (report.health().pairs().empty()) {
    out << "health of overlapping pairs: none (no two scans overlap)\n";
    return;
  }
  const bool registered = !report.registration().empty();
  out << "health of overlapping pairs (moving relative to fixed's surface"
      << (registered ? ", measured before registration" : "") << "):\n";
  PrintPairs(out, report.health());
  if (!registered) return;
  out << "registration (the motion applied to each scan; residual against the others):\n";
  PrintRegistration(out, report);
}

}  // namespace scanprep::client
