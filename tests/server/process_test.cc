// SPDX-License-Identifier: Apache-2.0
// End to end through the real service in-process: a generated noisy plane with spikes, unit and
// frame handling, GetInfo, and cancellation of a large job.
#include <atomic>
#include <chrono>
#include <cmath>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/time/clock.h"
#include "tests/server/service_fixtures.h"

namespace scanprep::testing {
namespace {

using ::testing::HasSubstr;

v1::JobHeader OutliersJob(v1::LengthUnit unit, double scanline_spacing) {
  v1::JobHeader header = SimpleHeader(scanline_spacing);
  header.set_unit(unit);
  header.mutable_options()->add_stages("outliers");
  return header;
}

PointCloud Scaled(const PointCloud& cloud, float factor) {
  PointCloud out = cloud;
  for (auto* axis : {&out.x, &out.y, &out.z}) {
    for (float& v : *axis) v *= factor;
  }
  return out;
}

TEST(Process, NoisyPlaneLosesItsSpikesAndKeepsThePlane) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(200, 0.5f);  // 40,000 + ~400 spikes
  const size_t spikes = std::count(scan.spike.begin(), scan.spike.end(), true);
  ASSERT_GT(spikes, 300u);

  v1::JobHeader header = OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5);
  header.mutable_options()->set_include_removed(true);
  std::set<v1::Progress::Phase> phases;
  std::set<std::string> stages_seen;
  std::mutex mu;
  client::CallOptions call;
  call.progress = [&](const v1::Progress& p) {
    std::lock_guard lock(mu);
    phases.insert(p.phase());
    if (p.phase() == v1::Progress::PHASE_PROCESSING) stages_seen.insert(p.stage());
  };
  auto result = server.Client().Process(header, scan.cloud, call);
  ASSERT_TRUE(result.ok()) << result.status();

  // include_removed: every point comes back, in order, with its flags.
  const PointCloud& out = result->cloud;
  ASSERT_EQ(out.size(), scan.cloud.size());
  size_t true_pos = 0, false_pos = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    ASSERT_EQ(out.x[i], scan.cloud.x[i]);
    if (out.flags[i] & v1::FLAG_REMOVED_OUTLIER) (scan.spike[i] ? true_pos : false_pos)++;
  }
  EXPECT_GE(true_pos, 0.95 * spikes);
  EXPECT_LE(false_pos, 40u);  // 0.1 % of the plane

  const v1::Report& report = result->report;
  EXPECT_EQ(report.job_id(), "test");
  EXPECT_EQ(report.points_received(), scan.cloud.size());
  EXPECT_EQ(report.points_invalid(), 0u);
  EXPECT_EQ(report.points_processed(), scan.cloud.size());
  EXPECT_EQ(report.points_returned(), scan.cloud.size());
  ASSERT_EQ(report.stages_size(), 3);  // the surface test pulls in the normals
  EXPECT_EQ(report.stages(0).name(), "neighbourhoods");
  EXPECT_EQ(report.stages(1).name(), "normals");
  const v1::StageReport& outliers = report.stages(2);
  EXPECT_EQ(outliers.name(), "outliers");
  EXPECT_EQ(outliers.points_in(), scan.cloud.size());
  EXPECT_EQ(outliers.points_out(), scan.cloud.size() - true_pos - false_pos);
  // The scan declared a scanline spacing, so it is a LINE scanner: r_min = √3·Δs + u (Eq. 2)
  // with the default uncertainty 0.1 mm.
  EXPECT_NEAR(report.stages(0).parameters().at("neighbourhoods.min_radius_mm"),
              std::sqrt(3.0) * 0.5 + 0.1, 1e-6);
  EXPECT_TRUE(report.budget_met());

  EXPECT_TRUE(phases.count(v1::Progress::PHASE_UPLOAD));
  EXPECT_TRUE(phases.count(v1::Progress::PHASE_PROCESSING));
  EXPECT_TRUE(phases.count(v1::Progress::PHASE_DOWNLOAD));
  EXPECT_TRUE(stages_seen.count("outliers"));
}

TEST(Process, KeptPointsOnlyComeInChunksOfAtMost32768) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(300, 0.5f);  // 90,000 + spikes
  auto stub = server.Stub();
  const std::vector<v1::ProcessRequest> requests =
      JobRequests(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5), scan.cloud, 30'000);
  std::vector<v1::ProcessResponse> responses;
  ASSERT_TRUE(RawCall(*stub, requests, &responses).ok());
  size_t points = 0, chunks = 0;
  for (const v1::ProcessResponse& r : responses) {
    if (!r.has_points()) continue;
    ++chunks;
    EXPECT_LE(r.points().xyz_size() / 3, 32'768);
    EXPECT_EQ(r.points().flags().find_first_not_of('\0'), std::string::npos);  // all kept
    points += r.points().xyz_size() / 3;
  }
  ASSERT_GE(responses.size(), 2u);
  const v1::ProcessResponse& report = responses[responses.size() - 2];  // the end message follows
  ASSERT_TRUE(report.has_report());
  EXPECT_EQ(points, report.report().points_returned());
  EXPECT_EQ(chunks, (points + 32'767) / 32'768);
  EXPECT_LT(points, scan.cloud.size());
}

TEST(Process, MetresAndAPoseGiveTheSameJobAsMillimetres) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(120, 0.5f);

  v1::JobHeader mm_header = OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5);
  mm_header.mutable_options()->set_include_removed(true);
  auto mm = server.Client().Process(mm_header, scan.cloud);
  ASSERT_TRUE(mm.ok()) << mm.status();

  // The same scan in metres, rotated 90° about z and shifted by (1, 2, 3) m into the common frame.
  v1::JobHeader m_header = OutliersJob(v1::LENGTH_UNIT_METRE, 0.0005);
  m_header.mutable_options()->set_include_removed(true);
  v1::RigidTransform* pose = m_header.mutable_scans(0)->mutable_to_common();
  pose->mutable_rotation()->set_z(std::sqrt(0.5));
  pose->mutable_rotation()->set_w(std::sqrt(0.5));
  pose->mutable_translation()->set_x(1);
  pose->mutable_translation()->set_y(2);
  pose->mutable_translation()->set_z(3);
  auto m = server.Client().Process(m_header, Scaled(scan.cloud, 0.001f));
  ASSERT_TRUE(m.ok()) << m.status();

  ASSERT_EQ(m->cloud.size(), scan.cloud.size());
  for (size_t i = 0; i < scan.cloud.size(); i += 97) {
    // R·(x, y, z) = (−y, x, z), then + t; results come back in metres.
    EXPECT_NEAR(m->cloud.x[i], -scan.cloud.y[i] * 0.001 + 1, 1e-6);
    EXPECT_NEAR(m->cloud.y[i], scan.cloud.x[i] * 0.001 + 2, 1e-6);
    EXPECT_NEAR(m->cloud.z[i], scan.cloud.z[i] * 0.001 + 3, 1e-6);
  }
  // Parameters are reported in mm either way, so both jobs derive the same ones.
  const auto& mm_params = mm->report.stages(0).parameters();
  const auto& m_params = m->report.stages(0).parameters();
  EXPECT_NEAR(m_params.at("neighbourhoods.global_radius_mm"),
              mm_params.at("neighbourhoods.global_radius_mm"), 1e-3);
  EXPECT_NEAR(m_params.at("neighbourhoods.min_radius_mm"),
              mm_params.at("neighbourhoods.min_radius_mm"), 1e-6);
  EXPECT_EQ(m->report.points_returned(), mm->report.points_returned());
  EXPECT_NEAR(static_cast<double>(m->report.stages(1).points_out()),
              static_cast<double>(mm->report.stages(1).points_out()), 2.0);
}

TEST(Process, UploadProcessingAndDownloadAreTimedAndFitInTheCall) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(200, 0.5f);
  client::CallOptions call;
  call.chunk_points = 4'096;  // several chunks each way, so both transfers take measurable time
  const absl::Time start = absl::Now();
  auto result =
      server.Client().Process(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5), scan.cloud, call);
  const double wall = absl::ToDoubleSeconds(absl::Now() - start);
  ASSERT_TRUE(result.ok()) << result.status();
  ASSERT_GT(result->report.points_returned(), 32'768u);  // at least two result chunks

  const double upload = result->transfer.upload;
  const double processing = result->report.processing_seconds();
  const double download = result->transfer.download;
  EXPECT_GT(upload, 0);
  EXPECT_GT(processing, 0);
  EXPECT_GT(download, 0);
  // The three phases follow one another within the call. The upload ends when the client reads
  // the server's confirmation, which can reach a busy client after processing began (ctest -j2
  // saw 7 ms), so the phases may overlap by a message's delay.
  EXPECT_LE(upload + processing + download, wall + 0.05);
}

TEST(Process, InvalidCoordinatesAreExcludedCountedAndWarned) {
  InProcessServer server;
  GeneratedScan scan = NoisyPlaneWithSpikes(60, 0.5f);
  const size_t n = scan.cloud.size();
  for (size_t i : {5u, 77u, 1000u}) scan.cloud.x[i] = std::numeric_limits<float>::quiet_NaN();
  scan.cloud.z[2000] = std::numeric_limits<float>::infinity();
  auto result = server.Client().Process(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5), scan.cloud);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->report.points_received(), n);
  EXPECT_EQ(result->report.points_invalid(), 4u);
  EXPECT_EQ(result->report.points_processed(), n - 4);
  EXPECT_EQ(result->report.stages(0).points_in(), n - 4);
  EXPECT_THAT(result->report.warnings(),
              ::testing::Contains(HasSubstr(
                  "4 of " + std::to_string(n) +
                  " points were excluded: 4 with NaN, infinite or out-of-range (> 1e+09 mm) "
                  "coordinates (the first, in upload order: 5, 77, 1000, 2000)")));
}

// A scan header without an uncertainty leaves u at its default: the report counts and names it;
// the same job stating u is the control.
TEST(Process, AnUnstatedUncertaintyIsCountedAndWarned) {
  InProcessServer server;
  const GeneratedScan scan = NoisyPlaneWithSpikes(40, 0.5f);
  for (const double u : {0.0, 0.05}) {
    v1::JobHeader header = OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5);
    header.mutable_scans(0)->set_uncertainty(u);
    auto result = server.Client().Process(header, scan.cloud);
    ASSERT_TRUE(result.ok()) << result.status();
    ASSERT_EQ(result->report.stages(0).name(), "neighbourhoods");
    EXPECT_EQ(result->report.stages(0).parameters().at("neighbourhoods.scans_default_uncertainty"),
              u == 0 ? 1 : 0);
    const auto warning = ::testing::Contains(HasSubstr("state no measuring uncertainty u"));
    if (u == 0) {
      EXPECT_THAT(result->report.warnings(), warning);
    } else {
      EXPECT_THAT(result->report.warnings(), ::testing::Not(warning));
    }
  }
}

TEST(Process, GetInfoListsStagesParametersAndLimits) {
  server::ServerOptions options;
  options.limits.max_points_per_job = 123'456;
  options.limits.default_budget_seconds = 30;
  options.max_concurrent_jobs = 3;
  InProcessServer server(options);
  auto info = server.Client().GetInfo(absl::Seconds(10));
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->version(), SCANPREP_VERSION);
  EXPECT_EQ(info->limits().max_points_per_job(), 123'456u);
  EXPECT_EQ(info->limits().max_chunk_points(), 65'536u);
  EXPECT_EQ(info->limits().max_concurrent_jobs(), 3u);
  EXPECT_EQ(info->limits().recommended_chunk_points(), 32'768u);
  EXPECT_EQ(info->default_budget_seconds(), 30);
  ASSERT_EQ(static_cast<size_t>(info->stages_size()), StageRegistry().size());
  const std::vector<std::string> defaults = DefaultStages();
  for (const v1::StageInfo& stage : info->stages()) {
    EXPECT_FALSE(stage.summary().empty()) << stage.name();
    EXPECT_EQ(stage.default_enabled(),
              std::find(defaults.begin(), defaults.end(), stage.name()) != defaults.end());
  }
  EXPECT_EQ(static_cast<size_t>(info->parameters_size()), AllParamSpecs().size());
  bool multiplier = false;
  for (const v1::ParameterInfo& p : info->parameters()) {
    if (p.name() == "outliers.multiplier") multiplier = p.default_value() == "2";
  }
  EXPECT_TRUE(multiplier);
}

TEST(Process, DefaultBudgetAppliesWhenTheJobStatesNone) {
  server::ServerOptions options;
  options.limits.default_budget_seconds = 600;
  InProcessServer server(options);
  v1::JobHeader header = OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5);
  (*header.mutable_budget()->mutable_stage_seconds())["outliers"] = 300;
  auto result = server.Client().Process(header, NoisyPlaneWithSpikes(50, 0.5f).cloud);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->report.budget_seconds(), 600);
  EXPECT_TRUE(result->report.budget_met());
  EXPECT_EQ(result->report.stages(2).name(), "outliers");
  EXPECT_EQ(result->report.stages(2).budget_seconds(), 300);
}

// budget_met alone is true when there was no budget; budget_outcome tells the three cases apart,
// for the job and for each stage.
TEST(Process, BudgetOutcomeTellsNoBudgetFromMetAndMissed) {
  InProcessServer server;
  const PointCloud cloud = NoisyPlaneWithSpikes(50, 0.5f).cloud;
  const std::pair<double, v1::BudgetOutcome> cases[] = {{0, v1::BUDGET_OUTCOME_NO_BUDGET},
                                                        {600, v1::BUDGET_OUTCOME_MET},
                                                        {1e-9, v1::BUDGET_OUTCOME_MISSED}};
  for (const auto& [seconds, outcome] : cases) {
    v1::JobHeader header = OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5);
    header.mutable_budget()->set_total_seconds(seconds);
    (*header.mutable_budget()->mutable_stage_seconds())["outliers"] = seconds;
    auto result = server.Client().Process(header, cloud);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->report.budget_outcome(), outcome) << seconds;
    EXPECT_EQ(result->report.budget_met(), outcome != v1::BUDGET_OUTCOME_MISSED) << seconds;
    ASSERT_EQ(result->report.stages(2).name(), "outliers");
    EXPECT_EQ(result->report.stages(2).budget_outcome(), outcome) << seconds;
    EXPECT_EQ(result->report.stages(0).budget_outcome(), v1::BUDGET_OUTCOME_NO_BUDGET);
  }
}

TEST(Process, CancelDuringProcessingEndsTheCallAndTheServerServesTheNext) {
  InProcessServer server;
  // 2.25 M points: the neighbourhood graph takes seconds, so processing is still running when
  // the cancel arrives.
  const GeneratedScan big = NoisyPlaneWithSpikes(1500, 0.5f);
  client::CallCanceller canceller;
  std::atomic<bool> cancelled{false};
  client::CallOptions call;
  call.canceller = &canceller;
  call.progress = [&](const v1::Progress& p) {
    if (p.phase() == v1::Progress::PHASE_PROCESSING && !cancelled.exchange(true))
      canceller.Cancel();
  };
  const auto start = std::chrono::steady_clock::now();
  auto result =
      server.Client().Process(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5), big.cloud, call);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kCancelled) << result.status();
  EXPECT_TRUE(cancelled);
  RecordProperty("cancelled_call_seconds", std::to_string(seconds));

  // The job slot and the arena are free again: a job runs to completion.
  auto next = server.Client().Process(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5),
                                      NoisyPlaneWithSpikes(50, 0.5f).cloud);
  EXPECT_TRUE(next.ok()) << next.status();
}

TEST(Process, DeadlineEndsALongJob) {
  InProcessServer server;
  const GeneratedScan big = NoisyPlaneWithSpikes(1000, 0.5f);
  client::CallOptions call;
  call.timeout = absl::Milliseconds(300);
  auto result =
      server.Client().Process(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5), big.cloud, call);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kDeadlineExceeded) << result.status();
  auto next = server.Client().Process(OutliersJob(v1::LENGTH_UNIT_MILLIMETRE, 0.5),
                                      NoisyPlaneWithSpikes(50, 0.5f).cloud);
  EXPECT_TRUE(next.ok()) << next.status();
}

}  // namespace
}  // namespace scanprep::testing
