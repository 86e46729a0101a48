#include "client/cli_args.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace scanprep::client {

std::string ParsedArgs::Get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second.back();
}

std::vector<std::string> ParsedArgs::All(const std::string& name) const {
  auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>{} : it->second;
}

absl::StatusOr<ParsedArgs> ParseArgs(const std::vector<std::string>& args,
                                     const std::vector<FlagSpec>& specs) {
  ParsedArgs parsed;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg.size() < 2 || arg[0] != '-') {
      parsed.positional.push_back(arg);
      continue;
    }
    const bool long_form = absl::StartsWith(arg, "--");
    std::string name = arg.substr(long_form ? 2 : 1);
    std::string value;
    const size_t eq = name.find('=');
    const bool inline_value = eq != std::string::npos;
    if (inline_value) {
      value = name.substr(eq + 1);
      name.resize(eq);
    }
    auto spec = std::find_if(specs.begin(), specs.end(), [&](const FlagSpec& s) {
      return long_form ? s.name == name : (!s.alias.empty() && s.alias == name);
    });
    if (spec == specs.end()) {
      return absl::InvalidArgumentError(absl::StrCat("unknown flag '", arg, "'"));
    }
    if (spec->kind == FlagSpec::kBool) {
      if (!inline_value) value = "true";
      if (value != "true" && value != "false") {
        return absl::InvalidArgumentError(
            absl::StrCat("--", spec->name, " takes true or false, not '", value, "'"));
      }
    } else if (!inline_value) {
      if (i + 1 >= args.size()) {
        return absl::InvalidArgumentError(absl::StrCat("--", spec->name, " needs a value"));
      }
      value = args[++i];
    }
    std::vector<std::string>& slot = parsed.values_[spec->name];
    if (!slot.empty() && spec->kind == FlagSpec::kValue) {
      return absl::InvalidArgumentError(absl::StrCat("--", spec->name, " given twice"));
    }
    slot.push_back(value);
  }
  return parsed;
}

absl::StatusOr<absl::Duration> GetDuration(const ParsedArgs& args, const std::string& name,
                                           absl::Duration fallback) {
  if (!args.Has(name)) return fallback;
  absl::Duration value;
  if (!absl::ParseDuration(args.Get(name), &value) || value <= absl::ZeroDuration()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--", name, ": '", args.Get(name), "' is not a positive duration (e.g. 90s, 5m)"));
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
