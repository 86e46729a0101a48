// SPDX-License-Identifier: Apache-2.0
// `scanprep process SCAN... -o OUT`: one job through the service, the result to a PLY, PCD, LAS or
// XYZ file chosen by the extension.
#include <filesystem>
#include <iostream>
#include <variant>

#include <Eigen/Geometry>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/time/time.h"
#include "client/call_error.h"
#include "client/commands.h"
#include "client/health_table.h"
#include "client/job_builder.h"
#include "client/job_call.h"
#include "client/output_check.h"
#include "client/preview.h"
#include "core/base/status_macros.h"
#include "core/io/scan_file.h"
#include "wire/convert.h"

namespace scanprep::client {
namespace {

namespace fs = std::filesystem;

// process's own flags.
constexpr char kOut[] = "out";
constexpr char kOutputFormat[] = "output_format";
constexpr char kPreview[] = "preview";
constexpr char kHealth[] = "health";

// Where the result goes: a file, its format by its extension, or standard output ("-") in
// --output_format. Checked before the scans are read or sent.
absl::StatusOr<io::ScanFormat> OutputFormat(const ParsedArgs& args) {
  const std::string out = args.Get(kOut);
  if (out != "-") {
    if (args.Has(kOutputFormat)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--output_format applies to -o - only; ", out, " has its extension"));
    }
    auto format = io::WritableFormatOf(out);
    if (format.ok()) return format;
    return absl::InvalidArgumentError(
        absl::StrCat("-o ", out,
                     ": the result is written as PLY, PCD, LAS or XYZ, chosen by the extension; "
                     "give a file name ending in .ply, .pcd, .las, .xyz, .asc or .txt (or -o - "
                     "with --output_format)"));
  }
  if (!args.Has(kOutputFormat)) {
    return absl::InvalidArgumentError(
        "-o - writes the result to standard output: say its format with --output_format (ply, "
        "pcd, las, xyz)");
  }
  auto format = io::ParseScanFormat(args.Get(kOutputFormat));
  if (format.ok() &&
      (!io::Writable(*format) || absl::EqualsIgnoreCase(args.Get(kOutputFormat), "laz"))) {
    return absl::InvalidArgumentError(
        "--output_format: the result is written as ply, pcd, las (uncompressed) or xyz");
  }
  return format;
}

std::string UnitName(v1::LengthUnit unit) {
  switch (unit) {
    case v1::LENGTH_UNIT_METRE:
      return "m";
    case v1::LENGTH_UNIT_MICROMETRE:
      return "um";
    case v1::LENGTH_UNIT_INCH:
      return "in";
    default:
      return "mm";
  }
}

// The input and the result side by side, with how far smoothing moved each kept point. What was
// sent is moved into the result's frame (local: relative to the job's origin) by each scan's
// to_common exactly as the server moves it (wire/convert.h, which works in millimetres; the
// result is in job units), and so is the first scan's sensor, which sets the view.
absl::Status WritePreview(const std::string& path, const PointCloud& sent,
                          const v1::JobHeader& header, const PointCloud& result) {
  SCANPREP_ASSIGN_OR_RETURN(const double mm_per_unit, MillimetresPerUnit(header.unit()));
  SCANPREP_ASSIGN_OR_RETURN(const Eigen::Vector3d origin_mm, OriginFromProto(header, mm_per_unit));
  PointCloud input = sent;
  std::vector<ScanFrame> frames;
  ScanMeta scanner;
  for (int s = 0; s < header.scans_size(); ++s) {
    const std::string field = absl::StrCat("header.scans[", s, "]");
    SCANPREP_ASSIGN_OR_RETURN(ScanFrame frame,
                              FrameFromProto(header.scans(s), mm_per_unit, origin_mm, field));
    if (s == 0) {
      SCANPREP_ASSIGN_OR_RETURN(scanner, ScanMetaFromProto(header.scans(0), frame, field));
      if (scanner.camera_position) *scanner.camera_position /= mm_per_unit;
    }
    frames.push_back(frame);
  }
  for (size_t i = 0; i < input.size(); ++i) {
    const size_t s = input.scan.empty() ? 0 : input.scan[i];
    if (s >= frames.size()) continue;
    const Eigen::Vector3d p = frames[s].ChunkPoint(input.point(i).cast<double>()) / mm_per_unit;
    input.x[i] = static_cast<float>(p.x());
    input.y[i] = static_cast<float>(p.y());
    input.z[i] = static_cast<float>(p.z());
  }
  PreviewPanels panels{.input = &input, .result = &result, .unit = UnitName(header.unit())};
  if (input.size() == result.size()) {
    panels.displacement.resize(result.size());
    for (size_t i = 0; i < result.size(); ++i) {
      panels.displacement[i] = result.removed(i) ? 0 : (result.point(i) - input.point(i)).norm();
    }
  }
  return WritePng(path, RenderPreview(panels, ChooseView(result, scanner)));
}

int RunProcess(const ParsedArgs& args) {
  if (!args.Has(kOut)) return FailUsage("process", "-o OUT.ply is required");
  auto out_format = OutputFormat(args);
  if (!out_format.ok()) return FailUsage("process", std::string(out_format.status().message()));
  if (args.Has(kPreview)) {
    if (absl::Status s = CheckPreviewPath(args.Get(kPreview)); !s.ok()) {
      return FailUsage("process", std::string(s.message()));
    }
  }
  // Where the result goes is checked before the scans are read or sent (exit 1, as a write
  // failure after the job would be).
  for (const auto& [flag, name] : {std::pair{kOut, "-o"}, std::pair{kPreview, "--preview"}}) {
    if (!args.Has(flag) || args.Get(flag) == "-") continue;
    if (absl::Status s = CheckWritable(name, args.Get(flag)); !s.ok()) {
      return Fail("process", std::string(s.message()));
    }
  }
  bool write_removed = false;
  auto sent = SendJob("process", args, [&](Job& job) {
    // The preview shows the removed points, so they come back; the output has them only if asked.
    write_removed = job.header.options().include_removed();
    if (args.Has(kPreview)) job.header.mutable_options()->set_include_removed(true);
  });
  if (const int* exit = std::get_if<int>(&sent)) return *exit;
  auto& [job, result, start, phases, server] = std::get<SentJob>(sent);
  const std::string out = args.Get(kOut);
  // The result is in the job's unit, the scan files' own, so a LAS input's grid fits it.
  result.cloud.grid = job.points.grid;
  if (absl::Status s = GatherSentAttributes(job.points, result); !s.ok()) {
    return Fail("process", std::string(s.message()));
  }
  const io::WriteOptions write_options{.include_removed = write_removed};
  const absl::Time write_start = absl::Now();
  // With the result on standard output, what is said about it goes to standard error.
  std::ostream& text = out == "-" ? std::cerr : std::cout;
  if (absl::Status s =
          out == "-" ? io::WriteScanStream(std::cout, *out_format, result.cloud, write_options)
                     : io::WriteScanFile(out, result.cloud, write_options);
      !s.ok()) {
    return Fail("process", std::string(s.message()));
  }
  if (out == "-" && !std::cout.flush()) return Fail("process", "cannot write to standard output");
  phases.write = absl::ToDoubleSeconds(absl::Now() - write_start);
  phases.total = absl::ToDoubleSeconds(absl::Now() - start);
  if (const int exit =
          WriteReportJson("process", args, result.report, phases, absl::StrCat("wrote ", out));
      exit != kExitOk) {
    return exit;
  }
  PrintSummary(text, result.report);
  PrintPhases(text, phases);
  if (const std::vector<std::string> left_out =
          io::AttributesLeftOut(*out_format, job.points.attributes);
      !left_out.empty()) {
    text << "note: " << absl::StrJoin(left_out, ", ")
         << " left out of the output: LAS has no place for them (write .ply, .pcd or .xyz)\n";
  }
  if (args.Bool(kHealth)) PrintHealth(text, result.report);
  if (args.Has(kPreview)) {
    if (absl::Status s = WritePreview(args.Get(kPreview), job.points, job.header, result.cloud);
        !s.ok()) {
      return Fail("process", std::string(s.message()));
    }
    text << "wrote the preview to " << args.Get(kPreview) << "\n";
  }
  text << "wrote " << (write_removed ? result.cloud.size() : result.cloud.CountKept())
       << " points to " << (out == "-" ? std::string("standard output") : out) << "\n";
  return BudgetExit("process", args, result.report);
}

}  // namespace

Command ProcessCommand() {
  std::vector<FlagSpec> flags = {
      {kOut, FlagSpec::kValue,
       "output file (required): .ply, .pcd, .las or .xyz/.asc/.txt; - for standard output", "o"},
      {kOutputFormat, FlagSpec::kValue, "format of -o -: ply, pcd, las or xyz"},
  };
  for (FlagSpec& flag : JobCallFlags()) flags.push_back(std::move(flag));
  flags.push_back({kPreview, FlagSpec::kValue,
                   "also draw the input and the result side by side as PNG: removed points by "
                   "reason, edges, smoothing displacement"});
  flags.push_back({kHealth, FlagSpec::kBool,
                   "also print the scans' and overlapping pairs' health (noise, residual, "
                   "misalignment; the \"health\" stage, in the default stages)"});
  return Command{
      .name = "process",
      .synopsis = "process SCAN... -o OUT.ply [flags]  (SCAN or OUT '-': standard input/output)",
      .summary =
          "send scans (.ply, .pcd, .e57, .las, .xyz/.asc/.txt/.pts; an E57 file holds several) "
          "through "
          "the service; write the result with normals and flags as PLY, PCD, LAS or XYZ (by -o's "
          "extension)",
      .flags = std::move(flags),
      .run = RunProcess,
  };
}

}  // namespace scanprep::client
