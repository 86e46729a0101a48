// SPDX-License-Identifier: Apache-2.0
#include "client/job_file.h"

#include <regex>
#include <utility>
#include <vector>

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/read_file.h"

namespace scanprep::client {
namespace {

namespace pb = google::protobuf;

// The enum values a job file may spell another way, as their proto names: the names from before
// the values took their enum's prefix (2026-11-24) and the --unit flag's short units.
std::string WithProtoEnumNames(const std::string& json) {
  static const auto* const kAliases = new std::vector<std::pair<std::regex, std::string>>{
      {std::regex(R"re(("unit"\s*:\s*")(MILLIMETRE|METRE|MICROMETRE|INCH)")re"),
       "$1LENGTH_UNIT_$2\""},
      {std::regex(R"re(("unit"\s*:\s*")mm")re"), "$1LENGTH_UNIT_MILLIMETRE\""},
      {std::regex(R"re(("unit"\s*:\s*")m")re"), "$1LENGTH_UNIT_METRE\""},
      {std::regex(R"re(("unit"\s*:\s*")um")re"), "$1LENGTH_UNIT_MICROMETRE\""},
      {std::regex(R"re(("unit"\s*:\s*")in")re"), "$1LENGTH_UNIT_INCH\""},
      {std::regex(R"re(("scanner_?[kK]ind"\s*:\s*")(LINE|FLEXIBLE)")re"), "$1SCANNER_KIND_$2\""},
  };
  std::string out = json;
  for (const auto& [pattern, replacement] : *kAliases) {
    out = std::regex_replace(out, pattern, replacement);
  }
  return out;
}

// The first string in `json` (read against `type`) that is no value of its enum field, as
// "unit: \"millimetres\" is not a LengthUnit (one of LENGTH_UNIT_MILLIMETRE, ...)"; empty when
// every enum value is known. Protobuf's own message names the value but neither the field nor the
// values it takes.
std::string UnknownEnumValue(const pb::Struct& json, const pb::Descriptor& type,
                             const std::string& path) {
  for (const auto& [key, value] : json.fields()) {
    const pb::FieldDescriptor* field = type.FindFieldByName(key);
    for (int f = 0; field == nullptr && f < type.field_count(); ++f) {
      if (type.field(f)->json_name() == key) field = type.field(f);
    }
    if (field == nullptr || field->is_map()) continue;
    std::vector<const pb::Value*> items;
    if (value.has_list_value()) {
      for (const pb::Value& item : value.list_value().values()) items.push_back(&item);
    } else {
      items.push_back(&value);
    }
    for (size_t i = 0; i < items.size(); ++i) {
      const std::string at =
          absl::StrCat(path, key, value.has_list_value() ? absl::StrCat("[", i, "]") : "");
      const pb::EnumDescriptor* values = field->enum_type();
      if (values != nullptr && items[i]->has_string_value() &&
          values->FindValueByName(items[i]->string_value()) == nullptr) {
        std::vector<std::string> names;
        for (int v = 0; v < values->value_count(); ++v) names.push_back(values->value(v)->name());
        return absl::StrCat(at, ": \"", items[i]->string_value(), "\" is not a ", values->name(),
                            " (one of ", absl::StrJoin(names, ", "), ")");
      }
      if (field->message_type() != nullptr && items[i]->has_struct_value()) {
        std::string inner =
            UnknownEnumValue(items[i]->struct_value(), *field->message_type(), at + ".");
        if (!inner.empty()) return inner;
      }
    }
  }
  return "";
}

}  // namespace

absl::StatusOr<v1::JobHeader> ReadJobFile(const std::string& path) {
  SCANPREP_ASSIGN_OR_RETURN(const std::string read, io::ReadFileToString(path));
  const std::string text = WithProtoEnumNames(read);
  v1::JobHeader header;
  pb::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = pb::util::JsonStringToMessage(text, &header, options);
  if (status.ok()) return header;
  pb::Struct json;
  const std::string enum_value = pb::util::JsonStringToMessage(text, &json).ok()
                                     ? UnknownEnumValue(json, *v1::JobHeader::descriptor(), "")
                                     : "";
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": not a JobHeader in JSON: ",
                   enum_value.empty() ? std::string(status.message()) : enum_value));
}

}  // namespace scanprep::client
