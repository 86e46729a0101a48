// SPDX-License-Identifier: Apache-2.0
// `scanprep simulate`: writes a generated laser-line scan as PLY files (one per scan) plus the
// job file with each scan's metadata, ready for `scanprep process`.
#include <google/protobuf/util/json_util.h>

#include <filesystem>
#include <fstream>
#include <iostream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/commands.h"
#include "client/job_builder.h"
#include "client/scan_generator.h"
#include "core/io/ply.h"

namespace scanprep::client {
namespace {

namespace fs = std::filesystem;

// The points of scan `s` as a one-scan cloud.
PointCloud ScanSubset(const PointCloud& cloud, uint32_t s) {
  PointCloud out;
  out.kind = cloud.kind;
  out.scans = {cloud.scans[s]};
  auto copy = [&](const auto& from, auto& to, size_t i) {
    if (!from.empty()) to.push_back(from[i]);
  };
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud.scan[i] != s) continue;
    copy(cloud.x, out.x, i);
    copy(cloud.y, out.y, i);
    copy(cloud.z, out.z, i);
    copy(cloud.scanline, out.scanline, i);
    copy(cloud.quality, out.quality, i);
    copy(cloud.intensity, out.intensity, i);
  }
  out.FinishLoading();
  return out;
}

int RunSimulate(const ParsedArgs& args) {
  if (!args.Has("out")) return FailUsage("simulate", "-o OUT.ply is required");
  size_t points = 0;
  if (!absl::SimpleAtoi(args.Get("points"), &points)) {
    return FailUsage("simulate",
                     absl::StrCat("--points: '", args.Get("points"), "' is not a point count"));
  }
  auto options = ParseGenerateOptions(args, points);
  if (!options.ok()) return FailUsage("simulate", std::string(options.status().message()));
  auto cloud = GenerateScan(*options);
  if (!cloud.ok()) return Fail("simulate", std::string(cloud.status().message()));

  // One file per scan, since `process` reads every file as one scan; a file's stem is its
  // scan's id, which is how the job file's metadata finds its scan.
  const fs::path out = args.Get("out");
  const fs::path stem = out.parent_path() / out.stem();
  v1::JobHeader header;
  header.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  header.set_scanner_kind(v1::SCANNER_KIND_LINE);
  std::vector<std::string> files;
  for (uint32_t s = 0; s < cloud->scans.size(); ++s) {
    const fs::path file =
        cloud->scans.size() == 1
            ? out
            : fs::path(absl::StrCat(stem.string(), "_", cloud->scans[s].id, ".ply"));
    PointCloud scan = ScanSubset(*cloud, s);
    if (absl::Status st = io::WritePly(file, scan); !st.ok()) {
      return Fail("simulate", std::string(st.message()));
    }
    v1::ScanHeader* scan_header = header.add_scans();
    *scan_header = ScanHeaderFromMeta(scan.scans[0]);
    scan_header->set_scan_id(file.stem().string());
    files.push_back(file.string());
    std::cout << absl::StrFormat(
        "wrote %s: %d points; scanline spacing %.4g mm, point spacing %.4g mm, uncertainty %.3g "
        "mm\n",
        file.string(), scan.size(), scan_header->scanline_spacing(), scan_header->point_spacing(),
        scan_header->uncertainty());
  }
  const std::string job_path = stem.string() + ".job.json";
  std::string json;
  google::protobuf::util::JsonPrintOptions json_options;
  json_options.add_whitespace = true;
  json_options.preserve_proto_field_names = true;  // snake_case, as every JSON the CLI writes
  (void)google::protobuf::util::MessageToJsonString(header, &json, json_options);
  std::ofstream job_file(job_path);
  job_file << json;
  if (!job_file) return Fail("simulate", absl::StrCat("cannot write ", job_path));
  std::cout << "wrote " << job_path << " (unit, camera, laser direction and spacings per scan)\n"
            << "process with: scanprep process " << absl::StrJoin(files, " ") << " --job "
            << job_path << " -o RESULT.ply\n";
  return 0;
}

}  // namespace

Command SimulateCommand() {
  std::vector<FlagSpec> flags = {
      {"points", FlagSpec::kValue, "about this many points in all (required)"},
      {"out", FlagSpec::kValue,
       "output PLY (required); with --scans 2, OUT_frontal.ply and OUT_oblique.ply", "o"},
  };
  for (FlagSpec& flag : GenerateFlags()) flags.push_back(std::move(flag));
  return Command{
      .name = "simulate",
      .synopsis =
          "simulate --points N -o OUT.ply [--part box|plane|sphere|cylinder] "
          "[--scans 1|2] [--seed S]",
      .summary =
          "write a simulated laser-line scan (millimetres, with noise and 1 % spikes) as "
          "PLY, plus OUT.job.json with its scanner metadata for `process --job`",
      .flags = std::move(flags),
      .run = RunSimulate,
  };
}

}  // namespace scanprep::client
