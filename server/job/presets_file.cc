// SPDX-License-Identifier: Apache-2.0
#include "server/job/presets_file.h"

#include <algorithm>
#include <filesystem>
#include <map>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "core/base/field_error.h"
#include "core/base/status_macros.h"
#include "core/io/read_file.h"

namespace scanprep::server {
namespace {

// Long enough for a scanner model and variant, short enough to echo in reports and errors.
constexpr size_t kMaxPresetNameBytes = 64;
// GetInfo lists every preset: at these limits (and at most one line per parameter, each value
// checked) its answer stays far within gRPC's 4 MiB message limit; a plant has a few scanner
// models, not thousands.
constexpr size_t kMaxPresets = 256;
constexpr size_t kMaxDescriptionBytes = 256;
constexpr uintmax_t kMaxFileBytes = 1 << 20;

bool ValidName(absl::string_view name) {
  return !name.empty() && name.size() <= kMaxPresetNameBytes &&
         std::all_of(name.begin(), name.end(), [](char c) {
           return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' ||
                  c == '.';
         });
}

// A validation error's problem without its "options.params['x']: " prefix: in a file the key
// is named by the caller.
std::string Problem(const absl::Status& status) {
  absl::string_view message = status.message();
  absl::ConsumePrefix(&message, absl::StrCat(ErrorField(status), ": "));
  return std::string(message);
}

absl::Status Bad(std::string_view where, std::string problem) {
  return absl::InvalidArgumentError(absl::StrCat(std::string(where), ": ", problem));
}

// Names that differ only in case ("Paper" beside "paper") are one name to the people who pick
// them.
bool Named(const std::vector<Preset>& presets, absl::string_view name) {
  return std::any_of(presets.begin(), presets.end(),
                     [&](const Preset& p) { return absl::EqualsIgnoreCase(p.name, name); });
}

}  // namespace

absl::StatusOr<std::vector<Preset>> ParsePresets(std::string_view text, std::string_view source) {
  std::vector<Preset> presets = BuiltinPresets();
  const size_t builtins = presets.size();
  std::map<std::string, int> key_lines;  // the current section's keys by line
  // Checks the finished section as a job's overrides are checked: as a whole, because one
  // parameter may bound another (outliers.k at most neighbourhoods.k) whichever line comes first.
  auto finish_section = [&]() -> absl::Status {
    if (presets.size() == builtins) return absl::OkStatus();
    const Preset& preset = presets.back();
    const absl::Status s = ValidatePreset(preset);
    if (s.ok()) return absl::OkStatus();
    const std::string field = ErrorField(s);
    absl::string_view key = field;
    absl::ConsumePrefix(&key, "options.params['");
    absl::ConsumeSuffix(&key, "']");
    const auto line = key_lines.find(std::string(key));
    return Bad(absl::StrCat(std::string(source), ":", line == key_lines.end() ? 0 : line->second),
               absl::StrCat("[", preset.name, "] ", std::string(key), ": ", Problem(s)));
  };
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(absl::string_view(text.data(), text.size()), '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    const std::string where = absl::StrCat(std::string(source), ":", line_number);
    if (absl::ConsumePrefix(&line, "[")) {
      if (!absl::ConsumeSuffix(&line, "]") || !ValidName(line)) {
        return Bad(where, absl::StrCat("expected '[name]', a name of letters, digits, '_', '-' "
                                       "and '.', at most ",
                                       kMaxPresetNameBytes, " bytes"));
      }
      SCANPREP_RETURN_IF_ERROR(finish_section());
      if (Named(presets, line)) {
        return Bad(where, absl::StrCat("[", line, "] ",
                                       Named(BuiltinPresets(), line)
                                           ? "is a built-in preset; a file cannot redefine it"
                                           : "is defined twice",
                                       " (names are compared ignoring case)"));
      }
      if (presets.size() - builtins == kMaxPresets) {
        return Bad(where, absl::StrCat("[", line, "]: more than ", kMaxPresets, " presets"));
      }
      presets.push_back({.name = std::string(line)});
      key_lines.clear();
      continue;
    }
    const std::vector<std::string> kv = absl::StrSplit(line, absl::MaxSplits('=', 1));
    const std::string key(absl::StripAsciiWhitespace(kv[0]));
    if (kv.size() != 2 || key.empty()) return Bad(where, "expected 'parameter = value'");
    if (presets.size() == builtins) {
      return Bad(where, absl::StrCat(key, ": outside a preset; start one with '[name]'"));
    }
    Preset& preset = presets.back();
    const std::string value(absl::StripAsciiWhitespace(kv[1]));
    if (key == "description") {
      if (value.size() > kMaxDescriptionBytes) {
        return Bad(where, absl::StrCat("[", preset.name, "] description: ", value.size(),
                                       " bytes, more than ", kMaxDescriptionBytes));
      }
      preset.description = value;
      continue;
    }
    if (!key_lines.emplace(key, line_number).second) {
      return Bad(where, absl::StrCat("[", preset.name, "] ", key, ": given twice"));
    }
    preset.params[key] = value;
  }
  SCANPREP_RETURN_IF_ERROR(finish_section());
  return presets;
}

absl::StatusOr<std::vector<Preset>> LoadPresets(const std::string& path) {
  if (path.empty()) return BuiltinPresets();
  // Checked before it is opened: opening a FIFO blocks until something writes to it, and the
  // server would hang at startup without a word.
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a regular file (a directory, FIFO, socket or device)"));
  }
  if (const uintmax_t size = std::filesystem::file_size(path, ec); !ec && size > kMaxFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", size, " bytes, more than ", kMaxFileBytes));
  }
  SCANPREP_ASSIGN_OR_RETURN(auto text, io::ReadFileToString(path));
  return ParsePresets(text, path);
}

}  // namespace scanprep::server
