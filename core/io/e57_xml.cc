// SPDX-License-Identifier: Apache-2.0
#include "core/io/e57_xml.h"

#include <expat.h>

#include <memory>

#include "absl/strings/str_cat.h"

namespace scanprep::io::e57 {
namespace {

constexpr size_t kMaxDepth = 64;

struct Builder {
  XmlNode root;
  std::vector<XmlNode*> open;  // the path from the root to the element being read
  bool too_deep = false;
  XML_Parser parser = nullptr;
};

void OnStart(void* data, const XML_Char* name, const XML_Char** attributes) {
  auto* b = static_cast<Builder*>(data);
  if (b->open.size() >= kMaxDepth) {
    b->too_deep = true;
    XML_StopParser(b->parser, XML_FALSE);
    return;
  }
  XmlNode* node = &b->root;
  if (!b->open.empty()) node = &b->open.back()->children.emplace_back();
  node->name = name;
  for (const XML_Char** a = attributes; a[0] != nullptr; a += 2) {
    node->attributes.emplace_back(a[0], a[1]);
  }
  b->open.push_back(node);
}

void OnEnd(void* data, const XML_Char*) { static_cast<Builder*>(data)->open.pop_back(); }

void OnText(void* data, const XML_Char* text, int length) {
  auto* b = static_cast<Builder*>(data);
  if (!b->open.empty()) b->open.back()->text.append(text, static_cast<size_t>(length));
}

}  // namespace

const XmlNode* XmlNode::Child(std::string_view child) const {
  for (const XmlNode& c : children) {
    if (c.name == child) return &c;
  }
  return nullptr;
}

std::string XmlNode::Attribute(std::string_view attribute, std::string fallback) const {
  for (const auto& [key, value] : attributes) {
    if (key == attribute) return value;
  }
  return fallback;
}

absl::StatusOr<XmlNode> ParseXml(std::string_view xml, const std::string& name_for_errors) {
  std::unique_ptr<XML_ParserStruct, decltype(&XML_ParserFree)> parser(XML_ParserCreate(nullptr),
                                                                      &XML_ParserFree);
  if (parser == nullptr) return absl::ResourceExhaustedError("cannot create an XML parser");
  Builder b;
  b.parser = parser.get();
  XML_SetUserData(parser.get(), &b);
  XML_SetElementHandler(parser.get(), OnStart, OnEnd);
  XML_SetCharacterDataHandler(parser.get(), OnText);
  // XML_Parse takes an int length; E57's XML sections are kilobytes, a hostile one is refused.
  if (xml.size() > (size_t{1} << 30)) {
    return absl::InvalidArgumentError(
        absl::StrCat(name_for_errors, ": XML section of ", xml.size(), " bytes (limit 1 GiB)"));
  }
  const XML_Status status =
      XML_Parse(parser.get(), xml.data(), static_cast<int>(xml.size()), XML_TRUE);
  if (b.too_deep) {
    return absl::InvalidArgumentError(absl::StrCat(name_for_errors, ": XML nested deeper than ",
                                                   kMaxDepth, " elements at line ",
                                                   XML_GetCurrentLineNumber(parser.get())));
  }
  if (status != XML_STATUS_OK) {
    return absl::InvalidArgumentError(absl::StrCat(
        name_for_errors, ": XML section, line ", XML_GetCurrentLineNumber(parser.get()), ": ",
        XML_ErrorString(XML_GetErrorCode(parser.get()))));
  }
  return std::move(b.root);
}

}  // namespace scanprep::io::e57
