// SPDX-License-Identifier: Apache-2.0
#include "core/io/text_fields.h"

#include <charconv>
#include <cstring>

namespace scanprep::io {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// from_chars rejects a leading '+', which some writers emit for positive values.
std::string_view DropPlus(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  return token;
}

}  // namespace

bool LineCursor::Next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  const char* begin = text_.data() + pos_;
  const void* newline = std::memchr(begin, '\n', text_.size() - pos_);
  const size_t length = newline != nullptr
                            ? static_cast<size_t>(static_cast<const char*>(newline) - begin)
                            : text_.size() - pos_;
  line = std::string_view(begin, length);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  pos_ += length + (newline != nullptr ? 1 : 0);
  ++next_line_number_;
  return true;
}

void SplitFields(std::string_view line, bool commas, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  const size_t n = line.size();
  auto separator = [&](char c) { return IsBlank(c) || (commas && c == ','); };
  while (i < n) {
    while (i < n && separator(line[i])) ++i;
    const size_t start = i;
    while (i < n && !separator(line[i])) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
}

bool ParseDouble(std::string_view token, double& out) {
  token = DropPlus(token);
  if (token.empty()) return false;
  const auto result = std::from_chars(token.data(), token.data() + token.size(), out);
  return result.ec == std::errc() && result.ptr == token.data() + token.size();
}

bool ParseUint64(std::string_view token, uint64_t& out) {
  token = DropPlus(token);
  if (token.empty()) return false;
  const auto result = std::from_chars(token.data(), token.data() + token.size(), out);
  return result.ec == std::errc() && result.ptr == token.data() + token.size();
}

}  // namespace scanprep::io
