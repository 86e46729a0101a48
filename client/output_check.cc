// SPDX-License-Identifier: Apache-2.0
#include "client/output_check.h"

#include <filesystem>
#include <system_error>

#include <unistd.h>

#include "absl/strings/str_cat.h"

namespace scanprep::client {

absl::Status CheckWritable(const std::string& flag, const std::string& path) {
  namespace fs = std::filesystem;
  const auto refused = [&](const std::string& why) {
    return absl::FailedPreconditionError(absl::StrCat(flag, " ", path, ": ", why));
  };
  std::error_code error;
  if (fs::is_directory(path, error)) return refused("is a folder; give a file name");
  if (fs::exists(path, error)) {
    return access(path.c_str(), W_OK) == 0 ? absl::OkStatus()
                                           : refused("exists and is not writable");
  }
  const fs::path parent = fs::path(path).parent_path();
  const std::string folder = parent.empty() ? "." : parent.string();
  if (!fs::is_directory(folder, error)) {
    return refused(absl::StrCat("the folder ", folder, " does not exist"));
  }
  if (access(folder.c_str(), W_OK | X_OK) != 0) {
    return refused(absl::StrCat("cannot create a file in ", folder));
  }
  return absl::OkStatus();
}

}  // namespace scanprep::client
