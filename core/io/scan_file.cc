// SPDX-License-Identifier: Apache-2.0
#include "core/io/scan_file.h"

#include <utility>

#include "absl/algorithm/container.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/e57.h"
#include "core/io/las.h"
#include "core/io/pcd.h"
#include "core/io/ply.h"
#include "core/io/xyz.h"

namespace scanprep::io {
namespace {

constexpr char kReadable[] = ".ply, .pcd, .e57, .las, .xyz, .asc, .txt, .pts";
constexpr char kWritten[] = ".ply, .pcd, .las, .xyz, .asc, .txt";

// One dispatch for files and streams: every reader and writer takes either a path or a stream
// (with a name for its errors) as its first arguments.
template <class... Source>
absl::StatusOr<PointCloud> ReadAs(ScanFormat format, std::vector<std::string>& warnings,
                                  const ReadOptions& options, const std::string& name,
                                  Source&&... source) {
  if (options.profile_gap > 0 && format != ScanFormat::kXyz) {
    warnings.push_back(absl::StrCat(
        name, ": the profile gap applies to text files only; this file's scanlines are its own"));
  }
  switch (format) {
    case ScanFormat::kPly:
      return ReadPly(std::forward<Source>(source)..., warnings);
    case ScanFormat::kPcd:
      return ReadPcd(std::forward<Source>(source)..., warnings);
    case ScanFormat::kE57:
      return ReadE57(std::forward<Source>(source)..., warnings);
    case ScanFormat::kLas:
      return ReadLas(std::forward<Source>(source)..., warnings);
    case ScanFormat::kXyz:
      return ReadXyz(std::forward<Source>(source)..., warnings, options.profile_gap);
  }
  return absl::InternalError("unknown scan format");
}

template <class Target>
absl::Status WriteAs(ScanFormat format, Target&& target, const PointCloud& cloud,
                     const WriteOptions& options) {
  switch (format) {
    case ScanFormat::kPly:
      return WritePly(target, cloud, options);
    case ScanFormat::kPcd:
      return WritePcd(target, cloud, options);
    case ScanFormat::kLas:
      return WriteLas(target, cloud, options);
    case ScanFormat::kXyz:
      return WriteXyz(target, cloud, options);
    case ScanFormat::kE57:
      break;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("cannot write this format (written: ", kWritten, ")"));
}

}  // namespace

absl::StatusOr<ScanFormat> ParseScanFormat(std::string_view name) {
  const std::string lower = absl::AsciiStrToLower(absl::string_view(name.data(), name.size()));
  if (lower == "ply") return ScanFormat::kPly;
  if (lower == "pcd") return ScanFormat::kPcd;
  if (lower == "e57") return ScanFormat::kE57;
  if (lower == "las" || lower == "laz") return ScanFormat::kLas;
  if (lower == "xyz" || lower == "asc" || lower == "txt" || lower == "pts") return ScanFormat::kXyz;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown scan format '", lower, "' (ply, pcd, e57, las, xyz, asc, txt, pts)"));
}

absl::StatusOr<ScanFormat> ScanFormatOf(const std::filesystem::path& path) {
  const std::string extension = path.extension().string();
  auto format = ParseScanFormat(extension.empty() ? extension : extension.substr(1));
  if (!format.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": unsupported file extension '",
                                                   extension, "' (supported: ", kReadable, ")"));
  }
  return format;
}

bool Writable(ScanFormat format) { return format != ScanFormat::kE57; }

std::vector<std::string> AttributesLeftOut(ScanFormat format,
                                           const std::vector<PointAttribute>& attributes) {
  if (format != ScanFormat::kLas) return {};
  const std::vector<std::string> kept = LasKeeps(attributes);
  std::vector<std::string> left_out;
  for (const PointAttribute& a : attributes) {
    if (absl::c_find(kept, a.name) == kept.end()) left_out.push_back(a.name);
  }
  return left_out;
}

absl::StatusOr<PointCloud> ReadScanFile(const std::filesystem::path& path,
                                        std::vector<std::string>& warnings,
                                        const ReadOptions& options) {
  SCANPREP_ASSIGN_OR_RETURN(ScanFormat format, ScanFormatOf(path));
  return ReadAs(format, warnings, options, path.string(), path);
}

absl::StatusOr<PointCloud> ReadScanStream(std::istream& in, ScanFormat format,
                                          const std::string& name_for_errors,
                                          std::vector<std::string>& warnings,
                                          const ReadOptions& options) {
  return ReadAs(format, warnings, options, name_for_errors, in, name_for_errors);
}

absl::StatusOr<ScanFormat> WritableFormatOf(const std::filesystem::path& path) {
  const std::string extension = absl::AsciiStrToLower(path.extension().string());
  auto format = ScanFormatOf(path);
  // PTS's count line is not written, and LAZ's compression is not either.
  if (!format.ok() || !Writable(*format) || extension == ".pts" || extension == ".laz") {
    return absl::InvalidArgumentError(absl::StrCat(path.string(), ": cannot write '",
                                                   path.extension().string(),
                                                   "' files (written: ", kWritten, ")"));
  }
  return format;
}

absl::Status WriteScanFile(const std::filesystem::path& path, const PointCloud& cloud,
                           const WriteOptions& options) {
  SCANPREP_ASSIGN_OR_RETURN(ScanFormat format, WritableFormatOf(path));
  return WriteAs(format, path, cloud, options);
}

absl::Status WriteScanStream(std::ostream& out, ScanFormat format, const PointCloud& cloud,
                             const WriteOptions& options) {
  return WriteAs(format, out, cloud, options);
}

}  // namespace scanprep::io
