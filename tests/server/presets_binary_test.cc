// SPDX-License-Identifier: Apache-2.0
// --presets_file on the real binaries: a bad file stops scanprep-server at startup naming the
// file, line, preset and key; a good one loads, `scanprep info` lists its presets with their
// overrides, and `scanprep process --preset` runs one, its report saying so.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "scanprep/v1/scanprep.pb.h"
#include "tests/server/server_process.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

class PresetsBinary : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("presets_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(PresetsBinary, ABadFileStopsTheServerNamingFileLinePresetAndKey) {
  const fs::path bad = WriteFile(dir_ / "bad.conf",
                                 "[acme-ls200]\n"
                                 "smoothing.lambda = 0.4\n"
                                 "smoothing.lamda = 0.5\n");
  const CommandResult r = RunCommand(absl::StrCat(SCANPREP_SERVER_BINARY,
                                                  " --plaintext --listen=127.0.0.1:0 "
                                                  "--metrics_listen= --presets_file=",
                                                  bad.string()));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr(absl::StrCat("scanprep-server: --presets_file: ", bad.string(),
                                               ":3: [acme-ls200] smoothing.lamda: unknown "
                                               "parameter (did you mean 'smoothing.lambda'?)")));
}

// A preset whose parameters multiply the work past --max_plan_cost could run no job: refused at
// startup naming it and what each parameter costs; with a larger limit, the same file loads.
TEST_F(PresetsBinary, ACostlyPresetStopsTheServerNamingItsCost) {
  const fs::path costly = WriteFile(dir_ / "costly.conf",
                                    "[slow]\n"
                                    "smoothing.iterations = 7\n"
                                    "neighbourhoods.min_radius_mm = 10000\n");
  const std::string server = absl::StrCat(SCANPREP_SERVER_BINARY,
                                          " --plaintext --listen=127.0.0.1:0 --metrics_listen= "
                                          "--presets_file=",
                                          costly.string());
  const CommandResult r = RunCommand(server);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("--presets_file: preset 'slow': the plan's estimated work is"));
  EXPECT_THAT(r.output, HasSubstr("smoothing.iterations=7: smoothing ×7"));
  EXPECT_THAT(r.output,
              HasSubstr("neighbourhoods.min_radius_mm=10000: smoothing ×3.4, neighbourhoods ×2.9"));

  ServerProcess allowed({"--presets_file=" + costly.string(), "--max_plan_cost=0"});
  EXPECT_GT(allowed.port(), 0) << allowed.Log();
}

// Control: the same preset without the typo loads and is used.
TEST_F(PresetsBinary, AGoodFileIsListedAndRunByTheCli) {
  const fs::path good = WriteFile(dir_ / "good.conf",
                                  "[acme-ls200]\n"
                                  "description = Acme LS-200\n"
                                  "smoothing.lambda = 0.4\n"
                                  "outliers.multiplier = 2.5\n");
  ServerProcess server({"--presets_file=" + good.string()});
  ASSERT_GT(server.port(), 0) << server.Log();
  const std::string cli = SCANPREP_CLI_BINARY;

  const CommandResult info = RunCommand(cli + " info --server " + server.target());
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_THAT(info.output, HasSubstr("  metrology (built-in)  no overrides\n"));
  EXPECT_THAT(info.output, HasSubstr("  paper (built-in)  normals.radius_mode=knn "
                                     "outliers.surface_sigmas=0 smoothing.method=mean "
                                     "smoothing.neighbourhood=knn\n"));
  EXPECT_THAT(info.output, HasSubstr("  acme-ls200  outliers.multiplier=2.5 smoothing.lambda=0.4\n"
                                     "      Acme LS-200\n"));

  const std::string scan = (dir_ / "sim.ply").string();
  const CommandResult sim = RunCommand(cli + " simulate --points 20000 -o " + scan);
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const fs::path report_path = dir_ / "report.json";
  const CommandResult run = RunCommand(
      cli + " process " + scan + " --job " + (dir_ / "sim.job.json").string() + " -o " +
      (dir_ / "out.ply").string() + " --preset acme-ls200 --param outliers.multiplier=3 " +
      "--report_json " + report_path.string() + " --server " + server.target());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::stringstream json;
  json << std::ifstream(report_path).rdbuf();
  v1::Report report;
  google::protobuf::util::JsonParseOptions lenient;
  lenient.ignore_unknown_fields = true;  // the CLI adds its own phases
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json.str(), &report, lenient).ok())
      << json.str();
  EXPECT_EQ(report.preset(), "acme-ls200");
  std::map<std::string, double> used;
  for (const v1::StageReport& stage : report.stages()) {
    used.insert(stage.parameters().begin(), stage.parameters().end());
  }
  EXPECT_EQ(used.at("smoothing.lambda"), 0.4);       // the preset's
  EXPECT_EQ(used.at("outliers.multiplier"), 3);      // --param beats it
  EXPECT_EQ(used.at("outliers.surface_sigmas"), 4);  // the default
  EXPECT_EQ(server.Terminate(), 0);
}

}  // namespace
}  // namespace scanprep::testing
