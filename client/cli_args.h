// SPDX-License-Identifier: Apache-2.0
// The CLI's subcommand flags, declared once as FlagSpecs and parsed by CLI11: "--name=value",
// "--name value", short aliases, boolean flags and flags that may be repeated (--param a=1
// --param b=2). The table also gives the usage text.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace scanprep::client {

struct FlagSpec {
  enum Kind { kValue, kBool, kRepeated };
  std::string name;  // without dashes
  Kind kind = kValue;
  std::string help;
  std::string alias;  // e.g. "o" for -o; may be empty
};

class ParsedArgs {
 public:
  std::vector<std::string> positional;

  bool Has(const std::string& name) const { return values_.count(name) > 0; }
  // The last value given, or `fallback`.
  std::string Get(const std::string& name, const std::string& fallback = "") const;
  std::vector<std::string> All(const std::string& name) const;
  bool Bool(const std::string& name) const { return Get(name, "false") == "true"; }

 private:
  friend absl::StatusOr<ParsedArgs> ParseArgs(const std::vector<std::string>&,
                                              const std::vector<FlagSpec>&);
  std::map<std::string, std::vector<std::string>> values_;
};

// INVALID_ARGUMENT for an unknown flag, a missing value or a repeated single-value flag.
absl::StatusOr<ParsedArgs> ParseArgs(const std::vector<std::string>& args,
                                     const std::vector<FlagSpec>& specs);

// The flag's value as a duration ("90s", "5m"), or `fallback` when absent; INVALID_ARGUMENT
// naming the flag when it is no positive duration.
absl::StatusOr<absl::Duration> GetDuration(const ParsedArgs& args, const std::string& name,
                                           absl::Duration fallback);
// The flag's value as a number >= `min`, or `fallback` when absent; INVALID_ARGUMENT naming the
// flag otherwise.
absl::StatusOr<double> GetNumber(const ParsedArgs& args, const std::string& name, double fallback,
                                 double min);

// One line per flag, for usage messages.
std::string FlagHelp(const std::vector<FlagSpec>& specs);

}  // namespace scanprep::client
