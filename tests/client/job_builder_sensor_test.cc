// SPDX-License-Identifier: Apache-2.0
// A scan's sensor (ScanHeader.sensor_id, issue 32) in every way `process` and `health` describe a
// job: the job file's scans, --sensor_id for every scan or for one, and a generated scan's meta.
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/cli_args.h"
#include "client/job_builder.h"

namespace scanprep::client {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// Two one-point scan files, left.xyz and right.xyz, and a job file naming their sensors.
class SensorIds : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / "job_builder_sensor";
    fs::create_directories(dir_);
    for (const char* stem : {"left", "right"})
      std::ofstream(dir_ / (std::string(stem) + ".xyz")) << "1 2 3\n";
    std::ofstream(dir_ / "cell.job.json") << R"({"unit": "LENGTH_UNIT_MILLIMETRE", "scans": [
        {"scan_id": "left", "sensor_id": "cell3-left"},
        {"scan_id": "right", "sensor_id": "cell3-right"}]})";
  }

  absl::StatusOr<Job> Build(std::vector<std::string> words) {
    words.insert(words.begin(), {(dir_ / "left.xyz").string(), (dir_ / "right.xyz").string()});
    auto args = ParseArgs(words, JobFlags());
    if (!args.ok()) return args.status();
    if (absl::Status s = CheckJobFlags(*args); !s.ok()) return s;
    return BuildJob(*args);
  }

  std::string JobFile() const { return (dir_ / "cell.job.json").string(); }

  fs::path dir_;
};

TEST_F(SensorIds, TheJobFileNamesEachScansSensor) {
  auto job = Build({"--job", JobFile()});
  ASSERT_TRUE(job.ok()) << job.status();
  ASSERT_EQ(job->header.scans_size(), 2);
  EXPECT_EQ(job->header.scans(0).sensor_id(), "cell3-left");
  EXPECT_EQ(job->header.scans(1).sensor_id(), "cell3-right");
}

TEST_F(SensorIds, OneFlagNamesEveryScansSensorAndScanEqualsIdOneScans) {
  auto all = Build({"--sensor_id", "bench-1"});
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->header.scans(0).sensor_id(), "bench-1");
  EXPECT_EQ(all->header.scans(1).sensor_id(), "bench-1");
  // Later flags win, over the job file's value too.
  auto one = Build({"--job", JobFile(), "--sensor_id", "bench-1", "--sensor_id", "right=bench-2"});
  ASSERT_TRUE(one.ok()) << one.status();
  EXPECT_EQ(one->header.scans(0).sensor_id(), "bench-1");
  EXPECT_EQ(one->header.scans(1).sensor_id(), "bench-2");
}

TEST_F(SensorIds, MistakesNameTheFlagAndTheScans) {
  EXPECT_THAT(Build({"--sensor_id", "middle=bench-1"}).status().message(),
              HasSubstr("the job has no scan 'middle' (its scans: left, right)"));
  for (const char* bad : {"", "left=", "=bench-1"}) {
    auto job = Build({"--sensor_id", bad});
    EXPECT_EQ(job.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(job.status().message(), HasSubstr("expected ID (every scan) or SCAN=ID")) << bad;
  }
}

TEST(GeneratedSensorIds, AScansMetaSensorIsSent) {
  ScanMeta meta;
  meta.id = "sim0";
  meta.sensor_id = "sim-sensor-a";
  EXPECT_EQ(ScanHeaderFromMeta(meta).sensor_id(), "sim-sensor-a");
}

// The rows a reader left out as unmeasured travel with the scan, for its invalid share.
TEST(GeneratedSensorIds, AScansUnmeasuredCountIsSent) {
  ScanMeta meta;
  meta.points_invalid = 17;
  EXPECT_EQ(ScanHeaderFromMeta(meta).points_unmeasured(), 17u);
}

}  // namespace
}  // namespace scanprep::client
