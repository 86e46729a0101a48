// SPDX-License-Identifier: Apache-2.0
// The XML section of an E57 file as a small element tree, parsed with expat: E57 readers only
// walk it (data3D, pose, prototype), so a tree of names, attributes and text is all it needs.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace scanprep::io::e57 {

struct XmlNode {
  std::string name;  // as written, with its prefix if any (E57's own elements have none)
  std::vector<std::pair<std::string, std::string>> attributes;
  std::string text;  // character data directly inside, CDATA included
  std::vector<XmlNode> children;

  // The first child named `child`, or nullptr.
  const XmlNode* Child(std::string_view child) const;
  // The attribute's value, or `fallback` when the element has none.
  std::string Attribute(std::string_view attribute, std::string fallback = "") const;
};

// The document element of `xml`. INVALID_ARGUMENT naming the line for malformed XML or an
// element nested deeper than E57 ever needs (64 levels), so hostile input cannot recurse deeply.
absl::StatusOr<XmlNode> ParseXml(std::string_view xml, const std::string& name_for_errors);

}  // namespace scanprep::io::e57
