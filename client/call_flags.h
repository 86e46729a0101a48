// SPDX-License-Identifier: Apache-2.0
// The flags that the commands sending a job share (`process`, `health`, `load`), each declared
// once: its name is a constant here, spelled nowhere else; its help and default are in
// CallFlagSpecs (the job's own flags in JobFlags, job_builder.h); its value is checked by
// CallFlags::Parse (the job's by CheckJobFlags). A flag thus means the same in every command.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/cli_args.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::client {

struct CallFlags {
  // How long the call and the job may take (--server: connection_flags.h).
  static constexpr char kTimeout[] = "timeout";
  static constexpr char kBudget[] = "budget";
  // What the job is, read by BuildJob: the files' unit, a job file, poses, stages, parameters,
  // the scans' metadata, the warnings that fail it and standard input's format.
  static constexpr char kUnit[] = "unit";
  static constexpr char kJob[] = "job";
  static constexpr char kConf[] = "conf";
  static constexpr char kStages[] = "stages";
  static constexpr char kParam[] = "param";
  static constexpr char kPreset[] = "preset";
  static constexpr char kScanlineSpacing[] = "scanline_spacing";
  static constexpr char kProfileGap[] = "profile_gap";
  static constexpr char kUncertainty[] = "uncertainty";
  static constexpr char kSensorId[] = "sensor_id";
  static constexpr char kIncludeRemoved[] = "include_removed";
  static constexpr char kStrict[] = "strict";
  static constexpr char kFailOn[] = "fail_on";
  static constexpr char kInputFormat[] = "input_format";
  // What the caller calls the job, echoed in the report, the server's log and the metrics'
  // exemplars: a job id and labels (part serial, station, program).
  static constexpr char kJobId[] = "job_id";
  static constexpr char kLabel[] = "label";

  std::string server;                     // the channel target --server names
  std::optional<absl::Duration> timeout;  // none: no deadline
  std::optional<double> budget_seconds;   // none: the job file's, else the server's default

  // --server, --timeout and --budget: INVALID_ARGUMENT, a usage error, for a value that does not
  // parse.
  static absl::StatusOr<CallFlags> Parse(const ParsedArgs& args);

  // --budget, when given, as the job's budget (over the job file's).
  void SetBudget(scanprep::v1::JobHeader& header) const;
};

// --server (with its default, or required), TLS, the job flags, --timeout and --budget.
std::vector<FlagSpec> CallFlagSpecs(bool server_required);

}  // namespace scanprep::client
