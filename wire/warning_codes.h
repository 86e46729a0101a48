// SPDX-License-Identifier: Apache-2.0
// core's WarningCode and scanprep.v1.WarningCode are the same list under two names: the proto's
// is core's stable name with the WARNING_CODE_ prefix (a test holds every core code to a proto
// value). Mapped by name, so neither side needs the other's numbers. Shared by the server (the
// report, options.fail_on) and the client (--fail_on); header-only, as neither links the other.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "core/stages/warning.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep {

inline constexpr std::string_view kProtoWarningCodePrefix = "WARNING_CODE_";

// WARNING_CODE_UNSPECIFIED for a core code without its proto value (the test's failure).
inline v1::WarningCode WarningCodeToProto(WarningCode code) {
  v1::WarningCode out = v1::WARNING_CODE_UNSPECIFIED;
  v1::WarningCode_Parse(std::string(kProtoWarningCodePrefix) + std::string(WarningCodeName(code)),
                        &out);
  return out;
}

// Nothing for WARNING_CODE_UNSPECIFIED or a number this build does not know.
inline std::optional<WarningCode> WarningCodeFromProto(int number) {
  if (!v1::WarningCode_IsValid(number)) return std::nullopt;
  const std::string_view name = v1::WarningCode_Name(static_cast<v1::WarningCode>(number));
  if (!name.starts_with(kProtoWarningCodePrefix)) return std::nullopt;
  return WarningCodeFromName(name.substr(kProtoWarningCodePrefix.size()));
}

}  // namespace scanprep
