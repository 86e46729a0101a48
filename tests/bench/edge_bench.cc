// SPDX-License-Identifier: Apache-2.0
// The edge decision against ground truth (docs/metrology.md "Edges"): for several simulated parts
// and noise levels, the share of points flagged EDGE by their true distance to the nearest sharp
// edge, among the points the measures stage judged and among those the default pipeline returns,
// with the user's metadata (u = σ) and with none; and the flat-face RMS against raw beside it.
//
//   edge_bench [points = 300000] [seed = 20261129]
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "tests/support/metrology.h"
#include "tests/support/metrology_job.h"

namespace scanprep::bench {
namespace {

// A seed no test uses.
constexpr uint64_t kSeed = 20261129;

std::string Share(const testing::FlaggedShare& b) {
  return b.points == 0 ? " – |" : absl::StrFormat(" %.1f |", 100 * b.share());
}

std::string Shares(const testing::FlaggedShare (&bands)[testing::kEdgeBands]) {
  std::string out;
  for (const testing::FlaggedShare& b : bands) out += Share(b);
  return out;
}

int Run(size_t points, uint64_t seed) {
  const struct {
    const char* name;
    sim::Part part;
  } parts[] = {{"stepped block", sim::Part::kSteppedBlock},
               {"box with bore", sim::Part::kBoxWithBore},
               {"cylinder", sim::Part::kCylinder},
               {"sphere", sim::Part::kSphere}};
  std::printf(
      "EDGE share (%%) by true distance to the nearest sharp edge, bands < 0.1 / 0.1–0.3 / "
      "0.3–1 / 1–3 / > 3 mm; %zu points, seed %llu, three laser-line sensors, 1 %% spikes.\n\n",
      points, static_cast<unsigned long long>(seed));
  std::printf(
      "| part | σ mm | metadata | judged < 0.1 | 0.1–0.3 | 0.3–1 | 1–3 | > 3 | returned < 0.1 | "
      "0.1–0.3 | 0.3–1 | 1–3 | > 3 | curved judged | returned | flat RMS × raw | curved × raw | "
      "s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& p : parts) {
    for (const double sigma : {0.01, 0.03}) {
      const sim::SimulatedCloud sim = testing::SimulateScan(p.part, sigma, points, seed);
      const testing::Metrology raw = testing::MeasureAgainstTruth(p.part, sim, sim.cloud);
      for (const bool metadata : {true, false}) {
        auto run = testing::RunStages(
            metadata ? testing::WithUserMetadata(sim, sigma) : testing::WithoutMetadata(sim), {});
        if (!run.ok()) {
          std::fprintf(stderr, "%s: %s\n", p.name, std::string(run.status().message()).c_str());
          return 1;
        }
        const testing::EdgeFlags flags = testing::EdgeFlagsAgainstTruth(sim, run->cloud);
        const testing::Metrology m = testing::MeasureAgainstTruth(p.part, sim, run->cloud);
        std::printf("| %s | %.2f | %s |%s%s%s%s %.2f | %.2f | %.1f |\n", p.name, sigma,
                    metadata ? "u = σ" : "none", Shares(flags.measured).c_str(),
                    Shares(flags.returned).c_str(), Share(flags.curved_measured).c_str(),
                    Share(flags.curved_returned).c_str(), m.flat.rms / raw.flat.rms,
                    m.curved.rms / raw.curved.rms, run->seconds);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

}  // namespace
}  // namespace scanprep::bench

int main(int argc, char** argv) {
  const size_t points = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 300'000;
  const uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : scanprep::bench::kSeed;
  if (points < 1000) {
    std::fprintf(stderr, "usage: edge_bench [points >= 1000] [seed]\n");
    return 2;
  }
  return scanprep::bench::Run(points, seed);
}
