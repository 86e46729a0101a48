// SPDX-License-Identifier: Apache-2.0
// `scanprep health` and `scanprep process --health` (issue 32) with the real binaries: a
// simulated two-scan job through a real server prints both scans with the sensors the command
// line named and their one overlapping pair, writes the same into --report_json, and writes no
// cloud; a sensor id the server refuses names its field.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include "scanprep/v1/scanprep.pb.h"
#include "tests/server/server_process.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {
namespace {

using ::testing::ContainsRegex;
using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

class HealthCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One directory per process: ctest runs each test of the suite as its own process, in parallel.
    dir_ = new fs::path(fs::path(::testing::TempDir()) / absl::StrCat("health_cli_", ::getpid()));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    const CommandResult sim =
        RunCommand(absl::StrCat(SCANPREP_CLI_BINARY, " simulate --points 40000 --scans 2 -o ",
                                (*dir_ / "sim.ply").string()));
    ASSERT_EQ(sim.exit_code, 0) << sim.output;
  }
  static void TearDownTestSuite() { delete dir_; }

  // `command` on the simulated pair (sim_frontal, sim_oblique) with its job file.
  static CommandResult Run(const ServerProcess& server, const std::string& command,
                           const std::string& flags) {
    return RunCommand(absl::StrCat(
        SCANPREP_CLI_BINARY, " ", command, " ", (*dir_ / "sim_frontal.ply").string(), " ",
        (*dir_ / "sim_oblique.ply").string(), " --job ", (*dir_ / "sim.job.json").string(),
        " --progress off --server ", server.target(), " ", flags));
  }

  static fs::path* dir_;
};

fs::path* HealthCli::dir_ = nullptr;

TEST_F(HealthCli, HealthPrintsBothScansAndTheirPairAndWritesNoCloud) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0) << server.Log();
  const fs::path report_path = *dir_ / "health.json";
  const CommandResult r =
      Run(server, "health",
          "--sensor_id sim_frontal=cell-a --sensor_id sim_oblique=cell-b --report_json " +
              report_path.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, ContainsRegex("\nsim_frontal +cell-a +[0-9]+ +0\\.[0-9]+ "));
  EXPECT_THAT(r.output, ContainsRegex("\nsim_oblique +cell-b +[0-9]+ +0\\.[0-9]+ "));
  EXPECT_THAT(r.output, ContainsRegex("\nsim_frontal +sim_oblique +[0-9]+ +-?[0-9]+\\.[0-9]+ "));
  EXPECT_THAT(r.output, Not(HasSubstr("wrote")));  // no cloud
  for (const auto& entry : fs::directory_iterator(*dir_)) {
    EXPECT_THAT(entry.path().filename().string(), Not(HasSubstr("out"))) << "a cloud was written";
  }

  std::stringstream json;
  json << std::ifstream(report_path).rdbuf();
  EXPECT_THAT(json.str(), HasSubstr("\"residual_median_mm\""));  // snake_case, as the proto
  v1::Report report;
  google::protobuf::util::JsonParseOptions lenient;
  lenient.ignore_unknown_fields = true;  // the CLI adds its own phases
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json.str(), &report, lenient).ok());
  ASSERT_EQ(report.health().scans_size(), 2);
  EXPECT_EQ(report.health().scans(0).sensor_id(), "cell-a");
  EXPECT_EQ(report.health().scans(1).sensor_id(), "cell-b");
  ASSERT_EQ(report.health().pairs_size(), 1);
  EXPECT_EQ(report.health().pairs(0).fixed_sensor_id(), "cell-a");
  EXPECT_EQ(report.health().pairs(0).moving_sensor_id(), "cell-b");
  // Only the stages health needs ran: nothing was cleaned away.
  for (const v1::StageReport& stage : report.stages()) {
    EXPECT_THAT(stage.name(), Not(::testing::AnyOf("smoothing", "simplification")));
  }
  EXPECT_EQ(server.Terminate(), 0);
}

TEST_F(HealthCli, ProcessWithHealthPrintsTheTableAfterTheSummary) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0) << server.Log();
  const CommandResult r =
      Run(server, "process", "--health --sensor_id bench -o " + (*dir_ / "out.xyz").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, ContainsRegex("phases: .*\nhealth of the scans:\n"));
  EXPECT_THAT(r.output, ContainsRegex("\nsim_oblique +bench +[0-9]+ "));
  EXPECT_THAT(r.output, ContainsRegex("\nsim_frontal +sim_oblique +[0-9]+ "));
  fs::remove(*dir_ / "out.xyz");
  EXPECT_EQ(server.Terminate(), 0);
}

TEST_F(HealthCli, MistakesExitLikeProcess) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0) << server.Log();
  const CommandResult stages = Run(server, "health", "--stages outliers");
  EXPECT_EQ(stages.exit_code, 2) << stages.output;  // health chooses its stages
  EXPECT_THAT(stages.output, HasSubstr("--stages"));
  // The server checks the id's alphabet; the refusal names the scan's field: fix the input, 4.
  const CommandResult bad = Run(server, "health", "--sensor_id 'cell a'");
  EXPECT_EQ(bad.exit_code, 4) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("header.scans[0].sensor_id"));
  EXPECT_EQ(server.Terminate(), 0);
}

}  // namespace
}  // namespace scanprep::testing
