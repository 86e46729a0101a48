// SPDX-License-Identifier: Apache-2.0
#include "client/call_flags.h"

#include <utility>

#include "client/connection_flags.h"
#include "client/job_builder.h"
#include "core/base/status_macros.h"

namespace scanprep::client {

absl::StatusOr<CallFlags> CallFlags::Parse(const ParsedArgs& args) {
  CallFlags flags;
  if (args.Has(kTimeout)) {
    SCANPREP_ASSIGN_OR_RETURN(flags.timeout, GetDuration(args, kTimeout, absl::ZeroDuration()));
  }
  if (args.Has(kBudget)) {
    SCANPREP_ASSIGN_OR_RETURN(flags.budget_seconds, GetNumber(args, kBudget, 0, 0));
  }
  SCANPREP_ASSIGN_OR_RETURN(flags.server, TargetFromArgs(args));
  return flags;
}

void CallFlags::SetBudget(scanprep::v1::JobHeader& header) const {
  if (budget_seconds) header.mutable_budget()->set_total_seconds(*budget_seconds);
}

std::vector<FlagSpec> CallFlagSpecs(bool server_required) {
  std::vector<FlagSpec> flags = {ServerFlag(server_required)};
  AddTlsFlags(flags);
  for (FlagSpec& flag : JobFlags()) flags.push_back(std::move(flag));
  flags.push_back({CallFlags::kTimeout, FlagSpec::kValue,
                   "deadline of each call, its attempts and waits included, e.g. 120s (default: "
                   "none)"});
  flags.push_back({CallFlags::kBudget, FlagSpec::kValue,
                   "time budget of the job in seconds (over the job file's and the server's "
                   "default); the report says whether it was met, and `load` fails when its "
                   "latency p99 exceeds it"});
  return flags;
}

}  // namespace scanprep::client
