// SPDX-License-Identifier: Apache-2.0
#include "client/cli_args.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <utility>

#include <CLI/CLI.hpp>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/did_you_mean.h"

namespace scanprep::client {

std::string ParsedArgs::Get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second.back();
}

std::vector<std::string> ParsedArgs::All(const std::string& name) const {
  auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>{} : it->second;
}

namespace {

// "unknown flag '--scanline_spacng' (did you mean '--scanline_spacing'?)": the nearest declared
// flag, by the same rule as a misspelt parameter or stage.
std::string UnknownFlagsMessage(const std::vector<std::string>& unknown,
                                const std::vector<FlagSpec>& specs) {
  std::vector<std::string> known;
  for (const FlagSpec& spec : specs) known.push_back("--" + spec.name);
  std::vector<std::string> named;
  for (const std::string& word : unknown) {
    const std::string flag = word.substr(0, word.find('='));
    named.push_back(absl::StrCat("'", flag, "'", DidYouMean(flag, known)));
  }
  return absl::StrCat("unknown flag ", absl::StrJoin(named, ", "));
}

}  // namespace

absl::StatusOr<ParsedArgs> ParseArgs(const std::vector<std::string>& args,
                                     const std::vector<FlagSpec>& specs) {
  ParsedArgs parsed;
  CLI::App app;
  app.set_help_flag();  // --help is the caller's (main.cc prints the command's usage)
  // One string vector per flag, empty when absent; a bool flag's value, "true" or "false", is
  // filled in after the parse.
  std::deque<bool> bools;
  std::vector<std::pair<CLI::Option*, const bool*>> bool_options;
  for (const FlagSpec& spec : specs) {
    const std::string names =
        absl::StrCat("--", spec.name, spec.alias.empty() ? "" : absl::StrCat(",-", spec.alias));
    std::vector<std::string>& slot = parsed.values_[spec.name];
    if (spec.kind == FlagSpec::kBool) {
      bool& value = bools.emplace_back(false);
      bool_options.emplace_back(app.add_flag(names, value), &value);
    } else {
      CLI::Option* option = app.add_option(names, slot);
      // One value per use ("--param a=1 file.ply": file.ply stays positional).
      option->expected(1)->allow_extra_args(false)->type_size(1);
      option->multi_option_policy(spec.kind == FlagSpec::kRepeated ? CLI::MultiOptionPolicy::TakeAll
                                                                   : CLI::MultiOptionPolicy::Throw);
    }
  }
  app.add_option("positional", parsed.positional);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 consumes from the back
  try {
    app.parse(reversed);
  } catch (const CLI::ExtrasError& e) {
    return absl::InvalidArgumentError(UnknownFlagsMessage(app.remaining(), specs));
  } catch (const CLI::ParseError& e) {
    return absl::InvalidArgumentError(e.what());
  }
  for (const auto& [option, value] : bool_options) {
    if (option->count() > 0) {
      parsed.values_[option->get_name().substr(2)].push_back(*value ? "true" : "false");
    }
  }
  for (auto it = parsed.values_.begin(); it != parsed.values_.end();) {
    it = it->second.empty() ? parsed.values_.erase(it) : std::next(it);
  }
  return parsed;
}

absl::StatusOr<absl::Duration> GetDuration(const ParsedArgs& args, const std::string& name,
                                           absl::Duration fallback) {
  if (!args.Has(name)) return fallback;
  absl::Duration value;
  if (!absl::ParseDuration(args.Get(name), &value) || value <= absl::ZeroDuration()) {
    return absl::InvalidArgumentError(absl::StrCat("--", name, ": '", args.Get(name),
                                                   "' is not a positive duration (e.g. 90s, 5m)"));
  }
  return value;
}

absl::StatusOr<double> GetNumber(const ParsedArgs& args, const std::string& name, double fallback,
                                 double min) {
  if (!args.Has(name)) return fallback;
  double value = 0;
  if (!absl::SimpleAtod(args.Get(name), &value) || !(value >= min) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, ": '", args.Get(name), "' is not a number >= ", min));
  }
  return value;
}

std::string FlagHelp(const std::vector<FlagSpec>& specs) {
  std::string text;
  for (const FlagSpec& s : specs) {
    std::string names = absl::StrCat(s.alias.empty() ? "" : absl::StrCat("-", s.alias, ", "), "--",
                                     s.name, s.kind == FlagSpec::kBool ? "" : " VALUE");
    names.resize(std::max<size_t>(names.size(), 28), ' ');
    absl::StrAppend(&text, "  ", names, " ", s.help,
                    s.kind == FlagSpec::kRepeated ? " (repeatable)" : "", "\n");
  }
  return text;
}

}  // namespace scanprep::client
