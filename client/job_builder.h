// SPDX-License-Identifier: Apache-2.0
// Turns the `process` command line into a job: the JobHeader (job file, then flags on top) and
// the points of every scan file, each file one scan in its own frame and file units (or, with a
// per-point scan column of several values, one scan per value).
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/cli_args.h"
#include "core/base/point_cloud.h"
#include "core/io/scan_file.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::client {

struct Job {
  scanprep::v1::JobHeader header;
  PointCloud points;               // points.scan indexes header.scans; points.grid a LAS input's
  std::vector<std::string> notes;  // things the user should know (dropped optional arrays)
};

// "m", "mm", "um", "in" (or the enum names METRE, ...).
absl::StatusOr<scanprep::v1::LengthUnit> ParseUnit(const std::string& text);

// The flags BuildJob reads, for the commands that build a job (process, load).
std::vector<FlagSpec> JobFlags();

// Flags used: --job, --conf, --unit, --stages, --param, --preset, --include_removed,
// --scanline_spacing, --uncertainty, --sensor_id; positional arguments are the scan files.
// The scan arguments' formats, before anything is read: a file's by its extension, "-"
// (standard input, at most once) by --input_format. INVALID_ARGUMENT: a usage error.
absl::StatusOr<std::vector<io::ScanFormat>> ScanArgumentFormats(const ParsedArgs& args);

// The option flags' own values (--unit, --param NAME=VALUE, --scanline_spacing, --uncertainty,
// --profile_gap, the form of --sensor_id) as BuildJob parses them, before any file is read:
// INVALID_ARGUMENT is a usage error (exit 2), not a failure of the job.
absl::Status CheckJobFlags(const ParsedArgs& args);

absl::StatusOr<Job> BuildJob(const ParsedArgs& args);

// Unless the header states its origin: the first scan with a points_offset gives it, moved into
// the common frame by that scan's to_common, so that the server's local frame lies at the data
// and the result comes back relative to it (the receiver adds it back). No scan with an offset,
// no origin: the header is what it was before origins existed.
void SetJobOrigin(scanprep::v1::JobHeader& header);

// The wire form of a scan's metadata, millimetres, identity pose.
scanprep::v1::ScanHeader ScanHeaderFromMeta(const ScanMeta& meta);

// INVALID_ARGUMENT for --unit, --job or --conf, which would contradict a generated cloud: a usage
// error, checked before the cloud is generated.
absl::Status CheckGeneratedJobFlags(const ParsedArgs& args);

// The job for a cloud already in millimetres and in the common frame (a generated scan): one
// ScanHeader per cloud.scans entry, then the option flags as BuildJob applies them
// (CheckGeneratedJobFlags first).
absl::StatusOr<Job> BuildJobFromCloud(const ParsedArgs& args, PointCloud cloud);

}  // namespace scanprep::client
