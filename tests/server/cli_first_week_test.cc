// SPDX-License-Identifier: Apache-2.0
// Issue 40, item 9: what cost a plant's integrator an afternoon in the first week, each through
// the real `scanprep` CLI and scanprep-server: a misspelt flag, a --timeout overrun, an output
// folder that is missing, a job id and labels, a job file's unit, health's download, the log.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "scanprep/v1/scanprep.pb.h"
#include "tests/server/server_process.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

CommandResult RunCli(const std::string& args) {
  return RunCommand(std::string(SCANPREP_CLI_BINARY) + " " + args);
}

// A folder of its own with a 30 x 30 plane scanned line by line, 0.5 mm apart.
class CliFirstWeek : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("first_week_" + std::to_string(getpid()));
    fs::create_directories(dir_);
    std::ofstream xyz(scan());
    for (int line = 0; line < 30; ++line) {
      for (int i = 0; i < 30; ++i) xyz << 0.5 * i << " " << 0.5 * line << " 0\n";
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string scan() const { return (dir_ / "plane.xyz").string(); }
  std::string at(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

// The report a --report_json file holds (its "phases", the client's, are not the report's).
v1::Report ReportFrom(const std::string& path) {
  std::ifstream in(path);
  const std::string json((std::istreambuf_iterator<char>(in)), {});
  v1::Report report;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = true;
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(json, &report, options).ok()) << json;
  return report;
}

// A misspelt flag printed 30 lines of usage and no suggestion: now the mistake, the nearest flag
// and where the list is, in three lines (exit 2).
TEST_F(CliFirstWeek, AMisspeltFlagNamesTheOneMeant) {
  const CommandResult r =
      RunCli("process " + scan() + " -o " + at("x.ply") + " --scanline_spacng 0.5");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("unknown flag '--scanline_spacng' (did you mean "
                                  "'--scanline_spacing'?)"));
  EXPECT_THAT(r.output, HasSubstr("scanprep process --help lists its flags"));
  const std::vector<std::string> lines = absl::StrSplit(r.output, '\n', absl::SkipEmpty());
  EXPECT_LE(lines.size(), 3u) << r.output;
  // Control: nothing near is suggested for a word that is near nothing.
  EXPECT_THAT(RunCli("process " + scan() + " -o " + at("x.ply") + " --frobnicate").output,
              Not(HasSubstr("did you mean")));
}

// A --timeout overrun exited 1, the code of a local failure; now 6, its own.
TEST_F(CliFirstWeek, ATimeoutOverrunExitsSix) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const CommandResult r = RunCli("process " + scan() + " -o " + at("x.ply") +
                                 " --progress off --timeout 1ms --server " + server.target());
  EXPECT_EQ(r.exit_code, 6) << r.output;
  EXPECT_THAT(r.output, HasSubstr("DEADLINE_EXCEEDED"));
  EXPECT_FALSE(fs::exists(at("x.ply")));
  EXPECT_EQ(server.Terminate(), 0);
}

// An output into a folder that does not exist failed only after the job had run; now before
// anything is sent: no server is listening on port 1, and the message is about the folder.
TEST_F(CliFirstWeek, AnOutputWithNowhereToGoFailsBeforeTheJob) {
  const std::string job = "process " + scan() + " --server 127.0.0.1:1 --progress off ";
  const std::string missing = at("no_such_folder/x");
  fs::create_directory(at("taken.ply"));
  for (const std::string& flags :
       {"-o " + missing + ".ply", "-o " + at("y.ply") + " --preview " + missing + ".png",
        "-o " + at("y.ply") + " --report_json " + missing + ".json", "-o " + at("taken.ply")}) {
    const CommandResult r = RunCli(job + flags);
    EXPECT_EQ(r.exit_code, 1) << flags << ": " << r.output;
    EXPECT_THAT(r.output, Not(HasSubstr("UNAVAILABLE"))) << flags;
    EXPECT_THAT(r.output, ::testing::AnyOf(HasSubstr("no_such_folder does not exist"),
                                           HasSubstr("is a folder")))
        << flags;
  }
  // Control: a writable output goes on to the call (which finds no server: exit 3).
  EXPECT_EQ(RunCli(job + "-o " + at("y.ply")).exit_code, 3);
}

// The CLI could set neither a job id nor labels; they come back in the report, and the server's
// log writes a UTF-8 id as it is (it wrote octal escapes).
TEST_F(CliFirstWeek, AJobIdAndLabelsReachTheReportAndTheLog) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const std::string job = "process " + scan() + " -o " + at("x.ply") +
                          " --progress off --stages outliers --server " + server.target();
  const CommandResult r = RunCli(job +
                                 " --job_id Prüfteil-7 --label serial=A123 --label "
                                 "station=3 --report_json " +
                                 at("r.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const v1::Report report = ReportFrom(at("r.json"));
  EXPECT_EQ(report.job_id(), "Prüfteil-7");
  EXPECT_EQ(report.labels().at("serial"), "A123");
  EXPECT_EQ(report.labels().at("station"), "3");
  EXPECT_EQ(server.Terminate(), 0);
  EXPECT_THAT(server.Log(), HasSubstr("job=\"Prüfteil-7\"")) << server.Log();
  const CommandResult bad = RunCli(job + " --label serial");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("--label 'serial': expected KEY=VALUE"));
}

// Logs were plain text, which a plant's collector cannot parse. With --log_format=json every line
// the server prints (startup on stdout, calls and lifecycle on stderr) is one JSON object, the
// call's fields typed; the startup lines still name the port as the scripts read it. A format it
// does not know is refused at startup, naming the flag.
TEST_F(CliFirstWeek, JsonLogsAreOneObjectALineWithTheCallsFields) {
  ServerProcess server({"--log_format=json"});
  ASSERT_GT(server.port(), 0) << server.Log();
  const CommandResult r =
      RunCli("process " + scan() + " -o " + at("x.ply") +
             " --progress off --stages outliers --job_id Prüfteil-8 --server " + server.target());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(server.Terminate(), 0);
  int calls = 0, lines = 0;
  const std::vector<std::string> log_lines = absl::StrSplit(server.Log(), '\n', absl::SkipEmpty());
  for (const std::string& line : log_lines) {
    google::protobuf::Struct parsed;
    ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(line, &parsed).ok()) << line;
    ++lines;
    const auto& f = parsed.fields();
    ASSERT_TRUE(f.contains("time") && f.contains("level")) << line;
    if (!f.contains("event")) continue;
    ++calls;
    EXPECT_EQ(f.at("event").string_value(), "process");
    EXPECT_EQ(f.at("job").string_value(), "Prüfteil-8");
    EXPECT_EQ(f.at("status").string_value(), "OK");
    EXPECT_EQ(f.at("points").number_value(), 30 * 30);  // the plane SetUp writes
    EXPECT_GT(f.at("seconds").number_value(), 0);
  }
  EXPECT_EQ(calls, 1);
  EXPECT_GE(lines, 5);  // listening, memory, metrics, the memory guard, the call, the signal
  const CommandResult bad =
      RunCommand(std::string(SCANPREP_SERVER_BINARY) + " --plaintext --log_format=yaml");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.output, HasSubstr("--log_format=yaml: the log is written as text or json"));
}

// "unit": "mm" in a job file was refused as `invalid value "mm"`, naming neither the field nor
// the values it takes. The --unit flag's short names are read; anything else is named with them.
TEST_F(CliFirstWeek, AJobFilesUnitIsReadAsTheFlagsOrNamedWithItsValues) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const std::string job = "process " + scan() + " -o " + at("x.ply") + " --progress off " +
                          "--stages outliers --job " + at("job.json") + " --server " +
                          server.target() + " --report_json " + at("r.json");
  std::ofstream(at("job.json")) << R"({"unit": "m", "jobId": "short"})";
  CommandResult r = RunCli(job);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(ReportFrom(at("r.json")).job_id(), "short");
  std::ofstream(at("job.json")) << R"({"unit": "millimetres"})";
  r = RunCli(job);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("unit: \"millimetres\" is not a LengthUnit (one of "
                                  "LENGTH_UNIT_UNSPECIFIED, LENGTH_UNIT_MILLIMETRE"));
  std::ofstream(at("job.json"))
      << R"({"options": {"failOn": ["WARNING_CODE_UNIT_SUSPECT", "LOUD"]}})";
  r = RunCli(job);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("options.failOn[1]: \"LOUD\" is not a WarningCode"));
  EXPECT_EQ(server.Terminate(), 0);
}

// `health` downloaded the whole cloud and wrote none of it; the report alone comes back now.
TEST_F(CliFirstWeek, HealthBringsBackTheReportAlone) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const CommandResult r = RunCli("health " + scan() +
                                 " --uncertainty 0.01 --progress off "
                                 "--server " +
                                 server.target() + " --report_json " + at("r.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const v1::Report report = ReportFrom(at("r.json"));
  EXPECT_EQ(report.points_received(), 900u);
  EXPECT_EQ(report.points_returned(), 0u);
  EXPECT_EQ(report.health().scans_size(), 1);
  EXPECT_EQ(server.Terminate(), 0);
}

// The address a listening TCP socket on `port` is bound to, as /proc/net/tcp writes it
// ("0100007F" for 127.0.0.1, "00000000" for every interface); empty when none listens there.
std::string ListeningAddress(int port) {
  std::ifstream in("/proc/net/tcp");
  std::string line;
  std::getline(in, line);  // the column names
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string slot, local, remote, state;
    fields >> slot >> local >> remote >> state;
    const size_t colon = local.find(':');
    if (state == "0A" && std::stoi(local.substr(colon + 1), nullptr, 16) == port) {
      return local.substr(0, colon);
    }
  }
  return "";
}

// The metrics port listened on every interface while gRPC was on loopback; now it takes gRPC's
// host unless told. Control: a host given is kept.
TEST(ServerFirstWeek, MetricsListenOnTheGrpcHostUnlessTold) {
  ServerProcess loopback({"--metrics_listen=:0"});
  ASSERT_GT(loopback.metrics_port(), 0) << loopback.Log();
  EXPECT_EQ(ListeningAddress(loopback.metrics_port()), "0100007F");
  ServerProcess everywhere({"--metrics_listen=0.0.0.0:0"});
  ASSERT_GT(everywhere.metrics_port(), 0) << everywhere.Log();
  EXPECT_EQ(ListeningAddress(everywhere.metrics_port()), "00000000");
  EXPECT_EQ(loopback.Terminate(), 0);
  EXPECT_EQ(everywhere.Terminate(), 0);
}

// A taken port made a plaintext server blame "the TLS certificate"; now the system's reason.
TEST(ServerFirstWeek, APortInUseIsNamedNotTheCertificate) {
  ServerProcess first;
  ASSERT_GT(first.port(), 0);
  const CommandResult r = RunCommand(absl::StrCat(SCANPREP_SERVER_BINARY,
                                                  " --plaintext --listen=127.0.0.1:", first.port(),
                                                  " --metrics_listen="));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr(absl::StrCat("cannot listen on 127.0.0.1:", first.port(),
                                               " (Address already in use)")));
  EXPECT_THAT(r.output, Not(HasSubstr("TLS")));
  EXPECT_EQ(first.Terminate(), 0);
}

}  // namespace
}  // namespace scanprep::testing
