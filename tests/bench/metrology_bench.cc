// SPDX-License-Identifier: Apache-2.0
// The metrology evaluation as a markdown table: the simulated three-scan stepped block (exact
// ground truth, σ = 0.01 mm, 1 % spikes) through outliers + smoothing and through the default
// pipeline, with the metadata a user gives and with none (one bare .xyz), beside the raw cloud
// and, where their libraries are installed, PCL MLS and CGAL bilateral smoothing on the raw
// cloud. Zones and definitions: tests/support/metrology.h.
//
//   metrology_bench [points = 1000000] [seed = 20261123]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/pipeline/presets.h"
#include "tests/bench/metrology_peers.h"
#include "tests/support/metrology.h"
#include "tests/support/metrology_job.h"

namespace scanprep::bench {
namespace {

using testing::Metrology;
using testing::ZoneError;

// A seed no test uses: the table is measured on a cloud the suite was not tuned on.
constexpr uint64_t kSeed = 20261123;
constexpr double kMlsRadiusMm = 0.42;
constexpr int kCgalK = 20;
constexpr double kCgalSharpnessDeg = 25;
constexpr int kCgalIterations = 3;

std::string Zone(const ZoneError& z, const ZoneError& raw) {
  if (z.points == 0) return "–";
  return absl::StrFormat("%.2f (%.2f×)", 1000 * z.rms, z.rms / raw.rms);
}

std::string Share(double value) { return std::isnan(value) ? "–" : absl::StrFormat("%.3f", value); }

void PrintRow(const std::string& name, const Metrology& m, const Metrology& raw, double seconds) {
  std::printf("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %zu | %.1f |\n", name.c_str(),
              Zone(m.flat, raw.flat).c_str(), Zone(m.edge, raw.edge).c_str(),
              Zone(m.convex, raw.convex).c_str(), Zone(m.concave, raw.concave).c_str(),
              Zone(m.curved, raw.curved).c_str(), Share(m.precision).c_str(),
              Share(m.recall).c_str(), absl::StrFormat("%.4f", m.coverage).c_str(), m.points_out,
              seconds);
  std::fflush(stdout);
}

std::string Flagged(const testing::FlaggedShare& judged, const testing::FlaggedShare& returned) {
  if (judged.points == 0) return "–";
  return absl::StrFormat("%.1f / %.1f", 100 * judged.share(), 100 * returned.share());
}

std::string EdgeRow(const std::string& name, const testing::EdgeFlags& f) {
  std::string row = "| " + name + " |";
  for (size_t b = 0; b < testing::kEdgeBands; ++b) {
    row += " " + Flagged(f.measured[b], f.returned[b]) + " |";
  }
  return row + " " + Flagged(f.curved_measured, f.curved_returned) + " |\n";
}

// Used by the optional PCL and CGAL comparisons only.
[[maybe_unused]] double Seconds(const std::function<void()>& run) {
  const auto start = std::chrono::steady_clock::now();
  run();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int Run(size_t points, uint64_t seed) {
  const sim::SimulatedCloud sim = testing::SimulateEvaluationScan(points, seed);
  const sim::Part part = testing::kEvaluationPart;
  const Metrology raw = testing::MeasureAgainstTruth(part, sim, sim.cloud);
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
  const ScanMeta& scan0 = sim.cloud.scans[0];
  std::printf(
      "Stepped block, %zu points in %zu scans, seed %llu, σ = %.3f mm, %.0f %% "
      "spikes, Δs = %.4f mm, Δp = %.4f mm, coverage radius %.3f mm; measured %s.\n"
      "RMS distance to the true surface in µm (ratio to raw); zones of "
      "tests/support/metrology.h.\n\n",
      sim.cloud.size(), sim.cloud.scans.size(), static_cast<unsigned long long>(seed),
      testing::kEvaluationSigmaMm, 100 * testing::kEvaluationSpikeShare, scan0.scanline_spacing,
      scan0.point_spacing, testing::CoverageRadiusMm(sim), date);
  std::printf(
      "| run | flat | edge ≤ %.0f mm | convex ≤ %.1f mm | concave ≤ %.1f mm | curved | "
      "P | R | coverage | points out | s |\n",
      testing::kEdgeZoneMm, testing::kSharpZoneMm, testing::kSharpZoneMm);
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  PrintRow("raw", raw, raw, 0);

  std::vector<std::string> notes;
  // The EDGE flag of each run against the true distance to the nearest sharp edge, printed after
  // the accuracy table.
  std::vector<std::string> edge_rows;
  const struct {
    const char* name;
    std::vector<std::string> stages;
    bool metadata;
    ParamOverrides params;
  } runs[] = {
      {"outliers + smoothing", {"outliers", "smoothing"}, true},
      {"default pipeline (preset metrology)", {}, true},
      {"preset paper", {}, true, *ResolvePreset(BuiltinPresets(), "paper", {})},
      {"outliers + smoothing, no metadata", {"outliers", "smoothing"}, false},
      {"default pipeline, no metadata", {}, false},
  };
  for (const auto& r : runs) {
    auto run = testing::RunStages(
        r.metadata ? testing::WithUserMetadata(sim) : testing::WithoutMetadata(sim), r.stages,
        r.params);
    if (!run.ok()) {
      std::fprintf(stderr, "%s: %s\n", r.name, std::string(run.status().message()).c_str());
      return 1;
    }
    PrintRow(r.name, testing::MeasureAgainstTruth(part, sim, run->cloud), raw, run->seconds);
    edge_rows.push_back(EdgeRow(r.name, testing::EdgeFlagsAgainstTruth(sim, run->cloud)));
    for (const Warning& w : run->report.warnings) notes.push_back(r.name + (": " + w.message));
  }

#ifdef SCANPREP_HAVE_PCL
  {
    PointCloud smoothed;
    const double s = Seconds([&] { smoothed = SmoothWithPclMls(sim.cloud, kMlsRadiusMm, 2); });
    PrintRow(absl::StrFormat("PCL MLS (r %.2f mm, order 2), raw input", kMlsRadiusMm),
             testing::MeasureAgainstTruth(part, sim, smoothed), raw, s);
  }
#else
  notes.push_back("PCL MLS row skipped: built without libpcl-dev");
#endif
#ifdef SCANPREP_HAVE_CGAL
  {
    PointCloud smoothed;
    const double s = Seconds([&] {
      smoothed = SmoothWithCgalBilateral(sim.cloud, kCgalK, kCgalSharpnessDeg, kCgalIterations);
    });
    PrintRow(absl::StrFormat("CGAL bilateral (k %d, %.0f°, %d rounds, jet normals), raw input",
                             kCgalK, kCgalSharpnessDeg, kCgalIterations),
             testing::MeasureAgainstTruth(part, sim, smoothed), raw, s);
  }
#else
  notes.push_back("CGAL bilateral row skipped: built without libcgal-dev");
#endif
  std::printf(
      "\nEDGE share (%%) by true distance to the nearest sharp edge, judged (every point the "
      "measures stage saw) / returned\n\n| run | < 0.1 mm | 0.1–0.3 | 0.3–1 | 1–3 | > 3 mm | "
      "curved |\n|---|---|---|---|---|---|---|\n");
  for (const std::string& row : edge_rows) std::printf("%s", row.c_str());
  if (!notes.empty()) std::printf("\n");
  for (const std::string& note : notes) std::printf("- %s\n", note.c_str());
  return 0;
}

}  // namespace
}  // namespace scanprep::bench

int main(int argc, char** argv) {
  const size_t points = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1'000'000;
  const uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : scanprep::bench::kSeed;
  if (points < 1000) {
    std::fprintf(stderr, "usage: metrology_bench [points >= 1000] [seed]\n");
    return 2;
  }
  return scanprep::bench::Run(points, seed);
}
