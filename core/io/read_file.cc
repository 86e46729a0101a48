// SPDX-License-Identifier: Apache-2.0
#include "core/io/read_file.h"

#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"

namespace scanprep::io {

absl::StatusOr<std::string> ReadFileToString(const std::filesystem::path& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) {
    return absl::NotFoundError(absl::StrCat("file not found: ", path.string()));
  }
  if (std::filesystem::is_directory(status)) {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": is a directory, not a file"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::UnavailableError(absl::StrCat(path.string(), ": cannot open for reading"));
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec)
    return absl::UnavailableError(
        absl::StrCat(path.string(), ": cannot get the file size: ", ec.message()));
  std::string data(static_cast<size_t>(size), '\0');
  in.read(data.data(), static_cast<std::streamsize>(data.size()));
  if (in.bad()) return absl::UnavailableError(absl::StrCat(path.string(), ": read error"));
  data.resize(static_cast<size_t>(in.gcount()));  // the file may have shrunk since file_size()
  return data;
}

absl::StatusOr<std::string> ReadStreamToString(std::istream& in,
                                               const std::string& name_for_errors) {
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad() || buffer.bad())
    return absl::UnavailableError(absl::StrCat(name_for_errors, ": read error"));
  return std::move(buffer).str();
}

}  // namespace scanprep::io
