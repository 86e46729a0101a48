// SPDX-License-Identifier: Apache-2.0
#include "core/io/scan_file.h"

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/io/e57.h"
#include "core/io/pcd.h"
#include "core/io/ply.h"
#include "core/io/xyz.h"

namespace scanprep::io {

absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path,
                                        std::vector<std::string>& warnings,
                                        const ReadOptions& options) {
  const std::string extension = absl::AsciiStrToLower(path.extension().string());
  if (extension == ".xyz" || extension == ".asc" || extension == ".txt" || extension == ".pts") {
    return ReadXyz(path, options.profile_gap);
  }
  if (options.profile_gap > 0) {
    warnings.push_back(absl::StrCat(path.string(),
                                    ": the profile gap applies to text files only; "
                                    "this file's scanlines are its own"));
  }
  if (extension == ".ply") return ReadPly(path, warnings);
  if (extension == ".pcd") return ReadPcd(path, warnings);
  if (extension == ".e57") return ReadE57(path, warnings);
  return absl::InvalidArgumentError(
      absl::StrCat(path.string(), ": unsupported file extension '", extension,
                   "' (supported: .ply, .pcd, .e57, .xyz, .asc, .txt, .pts)"));
}

absl::Status WriteScanFile(const std::filesystem::path& path, const PointCloud& cloud,
                           const WriteOptions& options) {
  const std::string extension = absl::AsciiStrToLower(path.extension().string());
  if (extension == ".ply") return WritePly(path, cloud, options);
  if (extension == ".pcd") return WritePcd(path, cloud, options);
  if (extension == ".xyz" || extension == ".asc" || extension == ".txt") {
    return WriteXyz(path, cloud, options);
  }
  return absl::InvalidArgumentError(
      absl::StrCat(path.string(), ": cannot write '", extension,
                   "' files (written: .ply, .pcd, .xyz, .asc, .txt)"));
}

}  // namespace scanprep::io
