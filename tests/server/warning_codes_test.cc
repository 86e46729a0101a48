// SPDX-License-Identifier: Apache-2.0
// Warnings a program can act on, through the API: every core code has its proto value, name for
// name; options.fail_on refuses a code the server does not know; and the CLI's --strict fails a
// file in metres sent as millimetres with FAILED_PRECONDITION naming UNIT_SUSPECT, while the same
// file sent with --unit m passes (the real binaries).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/call_error.h"
#include "core/io/ply.h"
#include "core/stages/warning.h"
#include "tests/server/server_process.h"
#include "tests/server/service_fixtures.h"
#include "tests/support/run_command.h"
#include "wire/warning_codes.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(WarningCodes, EveryCoreCodeHasItsProtoValueNameForName) {
  for (WarningCode code : AllWarningCodes()) {
    const v1::WarningCode proto = WarningCodeToProto(code);
    EXPECT_NE(proto, v1::WARNING_CODE_UNSPECIFIED) << WarningCodeName(code);
    EXPECT_EQ(v1::WarningCode_Name(proto), "WARNING_CODE_" + std::string(WarningCodeName(code)));
    EXPECT_EQ(WarningCodeFromProto(proto), code);
  }
  // And back: no proto value without its core code (a client could fail_on it to no effect).
  const auto* values = v1::WarningCode_descriptor();
  EXPECT_EQ(values->value_count(), static_cast<int>(AllWarningCodes().size()) + 1);
  for (int i = 0; i < values->value_count(); ++i) {
    const int number = values->value(i)->number();
    if (number == v1::WARNING_CODE_UNSPECIFIED) continue;
    EXPECT_TRUE(WarningCodeFromProto(number).has_value()) << values->value(i)->name();
  }
}

TEST(WarningCodes, FailOnAnUnknownCodeIsRefusedNamingTheEntry) {
  InProcessServer server;
  for (int number : {int{v1::WARNING_CODE_UNSPECIFIED}, 999}) {
    v1::JobHeader header = SimpleHeader();
    header.mutable_options()->add_fail_on(v1::WARNING_CODE_UNIT_SUSPECT);
    header.mutable_options()->add_fail_on(static_cast<v1::WarningCode>(number));
    auto result = server.Client().Process(header, NoisyPlaneWithSpikes(20, 0.5f).cloud);
    ASSERT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument) << result.status();
    const client::CallErrorDetails details = client::DetailsOf(result.status());
    EXPECT_EQ(details.reason, "INVALID_PARAMETER");
    ASSERT_EQ(details.field_violations.size(), 1u);
    EXPECT_EQ(details.field_violations[0].field, "header.options.fail_on[1]");
  }
}

// A plane scanned at 0.5 mm with 0.025 mm noise, written in metres.
fs::path MetrePlaneFile() {
  PointCloud plane = NoisyPlaneWithSpikes(120, 0.5f).cloud;
  for (size_t i = 0; i < plane.size(); ++i) {
    plane.x[i] *= 1e-3f, plane.y[i] *= 1e-3f, plane.z[i] *= 1e-3f;
  }
  const fs::path file = fs::path(::testing::TempDir()) / "plane_in_metres.ply";
  EXPECT_TRUE(io::WritePly(file, plane).ok());
  return file;
}

TEST(WarningCodes, StrictFailsAMetreFileSentAsMillimetresAndPassesItInMetres) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  const fs::path file = MetrePlaneFile();
  const fs::path out = fs::path(::testing::TempDir()) / "plane_out.ply";
  const std::string cli = absl::StrCat(SCANPREP_CLI_BINARY, " process ", file.string(), " -o ",
                                       out.string(), " --server ", server.target());
  // The plant's metadata in mm (spacing 0.5, u = σ = 0.025), the file's coordinates in metres.
  const std::string as_mm = cli + " --unit mm --scanline_spacing 0.5 --uncertainty 0.025";
  const std::string in_m = cli + " --unit m --scanline_spacing 0.0005 --uncertainty 0.000025";

  // Without --strict the job passes and the CLI prints the warning with its code.
  CommandResult r = RunCommand(as_mm);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("warning UNIT_SUSPECT: scan "));

  r = RunCommand(as_mm + " --strict");
  EXPECT_EQ(r.exit_code, 4) << r.output;  // fix the input
  EXPECT_THAT(r.output, HasSubstr("FAILED_PRECONDITION"));
  EXPECT_THAT(r.output, HasSubstr("reason UNIT_SUSPECT"));

  r = RunCommand(as_mm + " --fail_on SCAN_REPEATED,UNIT_SUSPECT");
  EXPECT_THAT(r.output, HasSubstr("reason UNIT_SUSPECT"));

  r = RunCommand(in_m + " --strict");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, Not(HasSubstr("UNIT_SUSPECT")));
  EXPECT_EQ(server.Terminate(), 0);
}

// Issue 39 finding 4: the same scan sent again after a re-export (every coordinate 1e-4 mm
// off) was counted 0 and processed as new data, with the result holding both. Now strict fails it
// (reason SCAN_REPEATED, naming the scan); the control, the plane again moved a third of its
// spacing across (another sampling of the same surface), passes.
TEST(WarningCodes, StrictFailsAScanSentAgainAfterAReExport) {
  InProcessServer server;
  const PointCloud plane = NoisyPlaneWithSpikes(60, 0.5f).cloud;
  for (const float moved : {1e-4f, 0.5f / 3}) {
    SCOPED_TRACE(moved);
    v1::JobHeader header = SimpleHeader();
    header.mutable_scans(0)->set_uncertainty(0.05);  // ε = u/100 = 5e-4 mm
    *header.add_scans() = header.scans(0);
    header.mutable_scans(1)->set_scan_id("again");
    header.mutable_options()->add_fail_on(v1::WARNING_CODE_SCAN_REPEATED);
    PointCloud twice = plane;
    twice.scans.push_back(ScanMeta{.id = "again"});
    for (size_t i = 0; i < plane.size(); ++i) {
      const bool re_export = moved < 1e-3f;
      twice.x.push_back(plane.x[i] + moved);
      twice.y.push_back(plane.y[i] + (re_export ? moved : 0.f));
      twice.z.push_back(plane.z[i] + (re_export ? -moved : 0.f));
      twice.scan.push_back(1);
      twice.scanline.push_back(plane.scanline[i]);
    }
    twice.FinishLoading();
    auto result = server.Client().Process(header, twice);
    if (moved > 1e-3f) {
      EXPECT_TRUE(result.ok()) << result.status();
      continue;
    }
    ASSERT_EQ(result.status().code(), absl::StatusCode::kFailedPrecondition) << result.status();
    EXPECT_EQ(client::DetailsOf(result.status()).reason, "SCAN_REPEATED");
    EXPECT_THAT(result.status().message(), HasSubstr("of scan 1's (again)"));
  }
}

// Issue 39 finding 5: a plane whose every point was put on scanline 0 (a reader or client bug)
// came back with 281 of 100 k points and only RADIUS_CAPPED to say why. Now its own code names it
// and --strict fails it; the same file with its rows as scanlines passes.
TEST(WarningCodes, StrictFailsScanlinesThatHoldAnArea) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  PointCloud plane = NoisyPlaneWithSpikes(120, 0.5f).cloud;
  const fs::path rows = fs::path(::testing::TempDir()) / "plane_rows.ply";
  ASSERT_TRUE(io::WritePly(rows, plane).ok());
  std::fill(plane.scanline.begin(), plane.scanline.end(), 0u);
  const fs::path one_line = fs::path(::testing::TempDir()) / "plane_one_line.ply";
  ASSERT_TRUE(io::WritePly(one_line, plane).ok());
  const fs::path out = fs::path(::testing::TempDir()) / "plane_lines_out.ply";
  const auto cli = [&](const fs::path& file) {
    return absl::StrCat(SCANPREP_CLI_BINARY, " process ", file.string(), " -o ", out.string(),
                        " --server ", server.target(),
                        " --unit mm --scanline_spacing 0.5 --uncertainty 0.025 --strict");
  };
  CommandResult r = RunCommand(cli(one_line));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_THAT(r.output, HasSubstr("reason SCANLINES_IMPLAUSIBLE"));
  r = RunCommand(cli(rows));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_THAT(r.output, Not(HasSubstr("SCANLINES_IMPLAUSIBLE")));
  EXPECT_EQ(server.Terminate(), 0);
}

TEST(WarningCodes, AnUnknownFailOnNameIsAUsageError) {
  const CommandResult r = RunCommand(absl::StrCat(
      SCANPREP_CLI_BINARY, " process x.ply -o y.ply --server 127.0.0.1:1 --fail_on UNIT_SUSPEKT"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.output, HasSubstr("unknown warning code 'UNIT_SUSPEKT'"));
}

}  // namespace
}  // namespace scanprep::testing
