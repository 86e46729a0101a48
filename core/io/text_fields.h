// SPDX-License-Identifier: Apache-2.0
// Line and field splitting plus whole-token number parsing (std::from_chars) shared by the
// text readers (ASCII PLY, XYZ, .conf).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

namespace scanprep::io {

// Walks a buffer line by line (LF or CRLF; a trailing '\r' is dropped), numbering lines from
// `first_line_number`.
class LineCursor {
 public:
  explicit LineCursor(std::string_view text, size_t first_line_number = 1)
      : text_(text), next_line_number_(first_line_number) {}

  // Returns false at the end of the buffer.
  bool Next(std::string_view& line);
  // Number of the line last returned by Next().
  size_t line_number() const { return next_line_number_ - 1; }
  // Byte offset just past the line last returned (past its '\n').
  size_t offset() const { return pos_; }

 private:
  std::string_view text_;
  size_t pos_ = 0;
  size_t next_line_number_;
};

// Splits on blanks (space, tab, '\r', '\v', '\f'), and on commas too when `commas`. `out` is
// cleared first; its capacity is kept so a caller can reuse it for every line.
void SplitFields(std::string_view line, bool commas, std::vector<std::string_view>& out);

// True when the whole token is a number (a leading '+' is accepted; "nan"/"inf" parse).
bool ParseDouble(std::string_view token, double& out);
bool ParseUint64(std::string_view token, uint64_t& out);

}  // namespace scanprep::io
