// SPDX-License-Identifier: Apache-2.0
// `scanprep info`: what the server offers (GetInfo), readably or as JSON.
#include <iostream>
#include <map>
#include <string>

#include <google/protobuf/util/json_util.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/call_error.h"
#include "client/commands.h"
#include "client/connection_flags.h"
#include "client/scanprep_client.h"

namespace scanprep::client {
namespace {

// "integer in [1, 64], at most neighbourhoods.k", "real in (0, 10000]", "one of {nn, loop}".
std::string Admits(const v1::ParameterInfo& p) {
  if (p.kind() == v1::PARAMETER_KIND_CHOICE) {
    return absl::StrCat("one of {", absl::StrJoin(p.choices(), ", "), "}");
  }
  std::string text =
      absl::StrCat(p.kind() == v1::PARAMETER_KIND_INTEGER ? "integer" : "real", " in ", p.range());
  if (!p.at_most().empty()) absl::StrAppend(&text, ", at most ", p.at_most());
  return text;
}

int RunInfo(const ParsedArgs& args) {
  auto target = TargetFromArgs(args);
  if (!target.ok()) return FailUsage("info", std::string(target.status().message()));
  const std::string& server = *target;
  auto credentials = CredentialsFromArgs(args);
  if (!credentials.ok()) return FailFlagFiles("info", credentials.status());
  auto info = ScanPrepClient::Connect(server, *credentials).GetInfo(absl::Seconds(10));
  if (!info.ok()) {
    return FailCall("info", server, info.status());
  }
  if (args.Bool("json")) {
    std::string json;
    google::protobuf::util::JsonPrintOptions options;
    options.add_whitespace = true;
    options.preserve_proto_field_names = true;
    options.always_print_primitive_fields = true;
    if (!google::protobuf::util::MessageToJsonString(*info, &json, options).ok()) {
      return Fail("info", "the server's answer cannot be written as JSON");
    }
    std::cout << json;
    return kExitOk;
  }
  const v1::Limits& limits = info->limits();
  std::cout << "scanprep server " << info->version() << " at " << server << "\n"
            << absl::StrFormat(
                   "limits: %d points per job, %d points per chunk (recommended %d), "
                   "%d concurrent jobs\n",
                   limits.max_points_per_job(), limits.max_chunk_points(),
                   limits.recommended_chunk_points(), limits.max_concurrent_jobs())
            << absl::StrFormat(
                   "        %d queued, %s; header within %gs, upload "
                   "messages at most %gs apart, uploads at least %g bytes/s\n",
                   limits.max_queued_jobs(),
                   limits.max_calls_per_peer() == 0
                       ? std::string("no cap per client host (hosts take turns)")
                       : absl::StrCat(limits.max_calls_per_peer(), " calls per client host"),
                   limits.header_timeout_seconds(), limits.idle_timeout_seconds(),
                   limits.min_upload_bytes_per_second())
            << absl::StrFormat(
                   "        memory capacity %.0f MiB for the running jobs, a job "
                   "estimated at %d B/point; %s\n",
                   limits.memory_budget_bytes() / 1048576.0, limits.bytes_per_point(),
                   limits.max_plan_cost() > 0
                       ? absl::StrFormat("a plan's work at most %g× the default's",
                                         limits.max_plan_cost())
                       : std::string("no limit on a plan's work"))
            << "default budget: "
            << (info->default_budget_seconds() > 0
                    ? absl::StrCat(info->default_budget_seconds(), " s")
                    : std::string("none"))
            << "\n\nstages (* = in the default pipeline):\n";
  for (const v1::StageInfo& stage : info->stages()) {
    std::cout << absl::StrFormat("  %s %-16s %s\n", stage.default_enabled() ? "*" : " ",
                                 stage.name(), stage.summary());
  }
  std::cout << "\nparameters (override with --param name=value):\n";
  for (const v1::ParameterInfo& p : info->parameters()) {
    std::cout << "  " << p.name() << "  " << Admits(p) << "; "
              << (p.default_derived() ? "derived default: " : "default ") << p.default_value()
              << "\n      " << p.description() << "\n";
  }
  std::cout << "\npresets (choose with --preset name; --param overrides them):\n";
  for (const v1::PresetInfo& preset : info->presets()) {
    // protobuf's map has no order: sorted, so that the listing is stable.
    const std::map<std::string, std::string> params(preset.params().begin(), preset.params().end());
    std::cout << "  " << preset.name() << (preset.built_in() ? " (built-in)" : "") << "  "
              << (params.empty() ? "no overrides"
                                 : absl::StrJoin(params, " ", absl::PairFormatter("=")))
              << "\n      " << preset.description() << "\n";
  }
  return 0;
}

}  // namespace

Command InfoCommand() {
  std::vector<FlagSpec> flags = {
      ServerFlag(/*required=*/false),
      {"json", FlagSpec::kBool,
       "print GetInfo's answer as JSON (proto field names, every field) instead of text"}};
  AddTlsFlags(flags);
  return Command{
      .name = "info",
      .synopsis =
          "info [--server HOST:PORT] [--json] [--tls_ca CA.pem [--tls_cert C.pem --tls_key K.pem]]",
      .summary = "show the server's version, limits, stages, parameters and presets",
      .flags = std::move(flags),
      .run = RunInfo,
  };
}

}  // namespace scanprep::client
