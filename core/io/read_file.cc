#include "core/io/read_file.h"

#include <fstream>
#include <iterator>
#include <system_error>

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
  return ReadStreamToString(in, path.string());
}

absl::StatusOr<std::string> ReadStreamToString(std::istream& in, const std::string& name_for_errors) {
  std::string data(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>{});
  if (in.bad()) return absl::UnavailableError(absl::StrCat(name_for_errors, ": read error"));
  return data;
}

}  // namespace scanprep::io
