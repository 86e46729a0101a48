// SPDX-License-Identifier: Apache-2.0
#include "core/stages/warning.h"

#include <array>

#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"

namespace scanprep {
namespace {

struct CodeName {
  WarningCode code;
  std::string_view name;
};

constexpr std::array kCodeNames = {
#define SCANPREP_WARNING_ENTRY(code, name) CodeName{WarningCode::code, name},
    SCANPREP_WARNING_CODES(SCANPREP_WARNING_ENTRY)
#undef SCANPREP_WARNING_ENTRY
};

constexpr std::array kCodes = [] {
  std::array<WarningCode, kCodeNames.size()> codes{};
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = kCodeNames[i].code;
  return codes;
}();

constexpr WarningCode kStrict[] = {
    WarningCode::kUnitSuspect,   WarningCode::kNoiseAboveUncertainty,
    WarningCode::kScanRepeated,  WarningCode::kPointsInvalid,
    WarningCode::kUnitUnchecked, WarningCode::kScanlinesImplausible,
};

// (absl::string_view: Debian's Abseil does not alias it to std::string_view.)
constexpr absl::string_view kCodePayload = "scanprep/warning_code";
constexpr absl::string_view kMessagePayload = "scanprep/warning_message";
constexpr absl::string_view kParamPayloadPrefix = "scanprep/warning_param/";

}  // namespace

std::span<const WarningCode> AllWarningCodes() { return kCodes; }

std::span<const WarningCode> StrictWarningCodes() { return kStrict; }

std::string_view WarningCodeName(WarningCode code) {
  return kCodeNames[static_cast<size_t>(code)].name;
}

std::optional<WarningCode> WarningCodeFromName(std::string_view name) {
  for (const CodeName& entry : kCodeNames) {
    if (entry.name == name) return entry.code;
  }
  return std::nullopt;
}

absl::Status FailOnWarnings(std::span<const Warning> warnings,
                            const std::set<WarningCode>& fail_on) {
  for (const Warning& w : warnings) {
    if (!fail_on.contains(w.code)) continue;
    const std::string name(WarningCodeName(w.code));
    absl::Status status = absl::FailedPreconditionError(
        absl::StrCat(w.message, " (the job fails on warning ", name, ": options.fail_on)"));
    status.SetPayload(kCodePayload, absl::Cord(name));
    status.SetPayload(kMessagePayload, absl::Cord(w.message));
    for (const auto& [key, value] : w.params) {
      status.SetPayload(absl::StrCat(kParamPayloadPrefix, key), absl::Cord(value));
    }
    return status;
  }
  return absl::OkStatus();
}

std::optional<Warning> FailedWarning(const absl::Status& status) {
  const auto name = status.GetPayload(kCodePayload);
  if (!name.has_value()) return std::nullopt;
  const std::optional<WarningCode> code = WarningCodeFromName(std::string(*name));
  if (!code) return std::nullopt;
  const auto message = status.GetPayload(kMessagePayload);
  Warning warning{*code, message ? std::string(*message) : std::string(), {}};
  status.ForEachPayload([&](absl::string_view url, const absl::Cord& value) {
    if (absl::ConsumePrefix(&url, kParamPayloadPrefix)) {
      warning.params[std::string(url)] = std::string(value);
    }
  });
  return warning;
}

void FoldRepeatedWarnings(std::vector<Warning>& warnings) {
  std::map<WarningCode, size_t> seen;
  std::map<WarningCode, std::pair<size_t, std::string>> left_out;  // count, the first's text
  std::vector<Warning> kept;
  for (Warning& w : warnings) {
    if (++seen[w.code] <= kMaxWarningsPerCode) {
      kept.push_back(std::move(w));
      continue;
    }
    auto& [count, first] = left_out[w.code];
    if (count++ == 0) first = std::move(w.message);
  }
  for (const auto& [code, folded] : left_out) {
    const auto& [count, first] = folded;
    kept.push_back(
        {code,
         absl::StrCat(count, " more ", std::string(WarningCodeName(code)), " warnings like the ",
                      kMaxWarningsPerCode, " above are left out of the report (at most ",
                      kMaxWarningsPerCode, " of a code are listed); the first: ", first),
         {{"warnings_left_out", absl::StrCat(count)}}});
  }
  warnings = std::move(kept);
}

}  // namespace scanprep
