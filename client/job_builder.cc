// SPDX-License-Identifier: Apache-2.0
#include "client/job_builder.h"

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/call_flags.h"
#include "client/job_file.h"
#include "core/base/status_macros.h"
#include "core/io/conf.h"
#include "core/io/read_file.h"
#include "core/io/scan_file.h"
#include "core/stages/warning.h"
#include "wire/warning_codes.h"

namespace scanprep::client {
namespace {

namespace fs = std::filesystem;
namespace v1 = ::scanprep::v1;

// --strict's codes and --fail_on's, as options.fail_on.
absl::Status SetFailOn(const ParsedArgs& args, v1::PipelineOptions& options) {
  std::set<WarningCode> codes;
  if (args.Bool(CallFlags::kStrict))
    codes.insert(StrictWarningCodes().begin(), StrictWarningCodes().end());
  if (args.Has(CallFlags::kFailOn)) {
    for (absl::string_view name :
         absl::StrSplit(args.Get(CallFlags::kFailOn), ',', absl::SkipEmpty())) {
      const std::optional<WarningCode> code =
          WarningCodeFromName(std::string_view(name.data(), name.size()));
      if (!code) {
        std::vector<std::string> known;
        for (WarningCode c : AllWarningCodes()) known.emplace_back(WarningCodeName(c));
        return absl::InvalidArgumentError(absl::StrCat("--fail_on: unknown warning code '", name,
                                                       "' (known: ", absl::StrJoin(known, ", "),
                                                       ")"));
      }
      codes.insert(*code);
    }
  }
  for (WarningCode code : codes) options.add_fail_on(WarningCodeToProto(code));
  return absl::OkStatus();
}

absl::StatusOr<double> ParseLength(const ParsedArgs& args, const std::string& flag) {
  double value = 0;
  if (!absl::SimpleAtod(args.Get(flag), &value) || !(value >= 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", flag, ": '", args.Get(flag), "' is not a length >= 0"));
  }
  return value;
}

// Copies an optional per-point array of one file; `keep` is false when some file lacks it.
template <class T>
void AppendOptional(bool keep, const std::vector<T>& from, std::vector<T>& to) {
  if (keep) to.insert(to.end(), from.begin(), from.end());
}

// The scans of one file: a per-point scan column (PLY `scan`, `scan_id`, `scan_index`) with
// several values makes one scan per value, in order of first appearance; else the file is one.
struct FileScans {
  std::vector<uint32_t> values;    // the column's values, one per scan
  std::vector<uint32_t> of_point;  // index into `values` per point; empty = all scan 0
};

FileScans SplitByScanColumn(const PointCloud& cloud) {
  FileScans f;
  std::map<uint32_t, uint32_t> index;
  for (uint32_t v : cloud.scan) {
    if (index.emplace(v, static_cast<uint32_t>(f.values.size())).second) f.values.push_back(v);
  }
  if (f.values.size() <= 1) return {};
  f.of_point.reserve(cloud.scan.size());
  for (uint32_t v : cloud.scan) f.of_point.push_back(index[v]);
  return f;
}

// `scan_files[s]`: the file scan s came from; every scan of a file gets the file's pose.
absl::Status ApplyConf(const std::string& conf_path, const std::vector<std::string>& scan_files,
                       v1::JobHeader& header) {
  SCANPREP_ASSIGN_OR_RETURN(auto entries, io::ReadConf(conf_path));
  for (size_t s = 0; s < scan_files.size(); ++s) {
    const std::string name = fs::path(scan_files[s]).filename().string();
    auto entry = std::find_if(entries.begin(), entries.end(),
                              [&](const io::ConfEntry& e) { return e.file == name; });
    if (entry == entries.end()) {
      return absl::NotFoundError(absl::StrCat(conf_path, " has no pose for ", name));
    }
    v1::RigidTransform* t = header.mutable_scans(s)->mutable_to_common();
    const Eigen::Quaterniond& q = entry->pose.rotation;
    t->mutable_rotation()->set_x(q.x());
    t->mutable_rotation()->set_y(q.y());
    t->mutable_rotation()->set_z(q.z());
    t->mutable_rotation()->set_w(q.w());
    t->mutable_translation()->set_x(entry->pose.translation.x());
    t->mutable_translation()->set_y(entry->pose.translation.y());
    t->mutable_translation()->set_z(entry->pose.translation.z());
  }
  return absl::OkStatus();
}

// Each use of a repeatable "KEY=VALUE" flag (--param, --label) into `to`, split at the first
// '='; a later use of a key overrides an earlier one and the job file's.
absl::Status AddKeyValues(const ParsedArgs& args, const char* flag, const char* form,
                          google::protobuf::Map<std::string, std::string>& to) {
  for (const std::string& value : args.All(flag)) {
    const size_t eq = value.find('=');
    if (eq == std::string::npos || eq == 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("--", flag, " '", value, "': expected ", form));
    }
    to[value.substr(0, eq)] = value.substr(eq + 1);
  }
  return absl::OkStatus();
}

absl::Status ApplyOptionFlags(const ParsedArgs& args, v1::JobHeader& header) {
  if (args.Has(CallFlags::kUnit)) {
    SCANPREP_ASSIGN_OR_RETURN(auto unit, ParseUnit(args.Get(CallFlags::kUnit)));
    header.set_unit(unit);
  } else if (header.unit() == v1::LENGTH_UNIT_UNSPECIFIED) {
    header.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  }
  v1::PipelineOptions* options = header.mutable_options();
  if (args.Has(CallFlags::kStages)) {
    options->clear_stages();
    for (absl::string_view s :
         absl::StrSplit(args.Get(CallFlags::kStages), ',', absl::SkipEmpty())) {
      options->add_stages(std::string(s));
    }
  }
  SCANPREP_RETURN_IF_ERROR(
      AddKeyValues(args, CallFlags::kParam, "name=value", *options->mutable_params()));
  if (args.Has(CallFlags::kPreset)) options->set_preset(args.Get(CallFlags::kPreset));
  if (args.Has(CallFlags::kJobId)) header.set_job_id(args.Get(CallFlags::kJobId));
  SCANPREP_RETURN_IF_ERROR(
      AddKeyValues(args, CallFlags::kLabel, "KEY=VALUE", *header.mutable_labels()));
  if (args.Bool(CallFlags::kIncludeRemoved)) options->set_include_removed(true);
  SCANPREP_RETURN_IF_ERROR(SetFailOn(args, *options));
  for (const auto& [flag, set] :
       {std::pair{CallFlags::kScanlineSpacing, &v1::ScanHeader::set_scanline_spacing},
        std::pair{CallFlags::kUncertainty, &v1::ScanHeader::set_uncertainty}}) {
    if (!args.Has(flag)) continue;
    SCANPREP_ASSIGN_OR_RETURN(auto value, ParseLength(args, flag));
    for (v1::ScanHeader& scan : *header.mutable_scans()) (scan.*set)(value);
  }
  return absl::OkStatus();
}

// One --sensor_id: "ID" names the sensor of every scan, "SCAN=ID" of the scan whose scan_id is
// SCAN ('=' is not in a sensor id's alphabet, so the forms cannot be confused).
struct SensorFlag {
  std::string scan;  // empty: every scan
  std::string sensor;
};

absl::StatusOr<std::vector<SensorFlag>> ParseSensorFlags(const ParsedArgs& args) {
  std::vector<SensorFlag> flags;
  for (const std::string& value : args.All(CallFlags::kSensorId)) {
    const size_t eq = value.find('=');
    SensorFlag flag = eq == std::string::npos
                          ? SensorFlag{.scan = "", .sensor = value}
                          : SensorFlag{.scan = value.substr(0, eq), .sensor = value.substr(eq + 1)};
    if (flag.sensor.empty() || (eq != std::string::npos && flag.scan.empty())) {
      return absl::InvalidArgumentError(
          absl::StrCat("--sensor_id '", value, "': expected ID (every scan) or SCAN=ID"));
    }
    flags.push_back(std::move(flag));
  }
  return flags;
}

// In command-line order, so a later flag overrides an earlier one (and the job file's value).
absl::Status ApplySensorFlags(const ParsedArgs& args, v1::JobHeader& header) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<SensorFlag> flags, ParseSensorFlags(args));
  for (const SensorFlag& flag : flags) {
    bool matched = false;
    for (v1::ScanHeader& scan : *header.mutable_scans()) {
      if (!flag.scan.empty() && scan.scan_id() != flag.scan) continue;
      scan.set_sensor_id(flag.sensor);
      matched = true;
    }
    if (!matched && !flag.scan.empty()) {
      std::vector<std::string> ids;
      for (const v1::ScanHeader& scan : header.scans()) ids.push_back(scan.scan_id());
      return absl::InvalidArgumentError(
          absl::StrCat("--sensor_id ", flag.scan, "=", flag.sensor, ": the job has no scan '",
                       flag.scan, "' (its scans: ", absl::StrJoin(ids, ", "), ")"));
    }
  }
  return absl::OkStatus();
}

void SetVec3(const Eigen::Vector3d& from, v1::Vec3* to) {
  to->set_x(from.x());
  to->set_y(from.y());
  to->set_z(from.z());
}

Eigen::Vector3d FromVec3(const v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

void SetJobOrigin(v1::JobHeader& header) {
  if (header.has_origin()) return;
  for (const v1::ScanHeader& scan : header.scans()) {
    if (!scan.has_points_offset()) continue;
    const v1::RigidTransform& t = scan.to_common();
    const v1::Quaternion& q = t.rotation();
    const Eigen::Quaterniond rotation = t.has_rotation()
                                            ? Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z())
                                            : Eigen::Quaterniond::Identity();
    SetVec3(rotation.normalized() * FromVec3(scan.points_offset()) + FromVec3(t.translation()),
            header.mutable_origin());
    return;
  }
}

std::vector<FlagSpec> JobFlags() {
  return {
      {CallFlags::kUnit, FlagSpec::kValue,
       "length unit of the files: m, mm, um or in (default: the job file's, else mm)"},
      {CallFlags::kJob, FlagSpec::kValue, "JobHeader as JSON; the flags below override it"},
      {CallFlags::kConf, FlagSpec::kValue,
       "scanalyze .conf with each file's pose (sent as to_common; the server applies it)"},
      {CallFlags::kStages, FlagSpec::kValue, "comma-separated stage list (see `scanprep info`)"},
      {CallFlags::kParam, FlagSpec::kRepeated, "parameter override name=value"},
      {CallFlags::kPreset, FlagSpec::kValue,
       "named parameter set (see `scanprep info`), e.g. paper or metrology; --param overrides it"},
      {CallFlags::kScanlineSpacing, FlagSpec::kValue, "scanline spacing of every scan, job unit"},
      {CallFlags::kProfileGap, FlagSpec::kValue,
       "text scan files (.xyz, .asc, .txt, .pts) written profile by profile: a jump longer than "
       "this (file units) between consecutive points starts a new scanline"},
      {CallFlags::kUncertainty, FlagSpec::kValue, "measuring uncertainty of every scan, job unit"},
      {CallFlags::kSensorId, FlagSpec::kRepeated,
       "the physical sensor that took the scans, for their health (over the job file's): ID for "
       "every scan, or SCAN=ID for the scan named SCAN (its file's stem); repeatable"},
      {CallFlags::kIncludeRemoved, FlagSpec::kBool, "also return removed points, flagged"},
      {CallFlags::kStrict, FlagSpec::kBool,
       "fail the job (FAILED_PRECONDITION) on a warning that the request is probably wrong: "
       "UNIT_SUSPECT, NOISE_ABOVE_UNCERTAINTY, SCAN_REPEATED, POINTS_INVALID, UNIT_UNCHECKED, "
       "SCANLINES_IMPLAUSIBLE"},
      {CallFlags::kFailOn, FlagSpec::kValue,
       "fail the job on these warning codes, comma-separated (docs/api.md), e.g. UNIT_SUSPECT"},
      {CallFlags::kInputFormat, FlagSpec::kValue,
       "format of the scan read from standard input (SCAN '-'): ply, pcd, e57, las or xyz"},
      {CallFlags::kJobId, FlagSpec::kValue,
       "the job's id, echoed in the report and the server's log (over the job file's)"},
      {CallFlags::kLabel, FlagSpec::kRepeated,
       "a label KEY=VALUE echoed in the report, e.g. serial=A123 (over the job file's)"},
  };
}

absl::StatusOr<v1::LengthUnit> ParseUnit(const std::string& text) {
  static const std::map<std::string, v1::LengthUnit> kUnits = {
      {"mm", v1::LENGTH_UNIT_MILLIMETRE},         {"m", v1::LENGTH_UNIT_METRE},
      {"um", v1::LENGTH_UNIT_MICROMETRE},         {"in", v1::LENGTH_UNIT_INCH},
      {"MILLIMETRE", v1::LENGTH_UNIT_MILLIMETRE}, {"METRE", v1::LENGTH_UNIT_METRE},
      {"MICROMETRE", v1::LENGTH_UNIT_MICROMETRE}, {"INCH", v1::LENGTH_UNIT_INCH}};
  auto it = kUnits.find(text);
  if (it == kUnits.end()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown unit '", text, "' (use m, mm, um or in)"));
  }
  return it->second;
}

namespace {

// A scan argument's format: a file's by its extension, standard input's ("-") by --input_format.
absl::StatusOr<io::ScanFormat> ScanArgumentFormat(const std::string& file, const ParsedArgs& args) {
  if (file != "-") return io::ScanFormatOf(file);
  if (!args.Has(CallFlags::kInputFormat)) {
    return absl::InvalidArgumentError(
        "SCAN '-' reads standard input: say its format with --input_format (ply, pcd, e57, las, "
        "xyz)");
  }
  return io::ParseScanFormat(args.Get(CallFlags::kInputFormat));
}

absl::StatusOr<PointCloud> ReadScanArgument(const std::string& file, io::ScanFormat format,
                                            std::vector<std::string>& notes,
                                            const io::ReadOptions& options) {
  if (file != "-") return io::ReadScanFile(file, notes, options);
  return io::ReadScanStream(std::cin, format, "standard input", notes, options);
}

// One scan file read: its points and the scans they make.
struct FileRead {
  PointCloud cloud;
  FileScans split;
  uint32_t first_scan = 0;  // the index of its first scan in the header
};

// The ids of a file's scans: its stem ("stdin" for standard input), or STEM#VALUE per value of
// its scan column (noted).
std::vector<std::string> ScanIds(const std::string& file, const FileScans& split,
                                 std::vector<std::string>& notes) {
  const std::string stem = file == "-" ? "stdin" : fs::path(file).stem().string();
  if (split.values.empty()) return {stem};
  std::vector<std::string> ids;
  for (uint32_t v : split.values) ids.push_back(absl::StrCat(stem, "#", v));
  notes.push_back(absl::StrCat(file, ": its scan column holds ", ids.size(), " scans, sent as ",
                               ids.front(), " … ", ids.back()));
  return ids;
}

// Appends the file's scans to the header, in order; a job-file scan whose scan_id is a scan's id
// supplies its metadata and is taken out of `from_job`. `scan_files` gets the file once per scan.
void AddFileScans(const std::string& file, const FileRead& read,
                  std::vector<v1::ScanHeader>& from_job, Job& job,
                  std::vector<std::string>& scan_files) {
  const std::vector<std::string> ids = ScanIds(file, read.split, job.notes);
  const PointCloud& cloud = read.cloud;
  for (size_t k = 0; k < ids.size(); ++k) {
    const std::string& id = ids[k];
    auto match = std::find_if(from_job.begin(), from_job.end(),
                              [&](const v1::ScanHeader& s) { return s.scan_id() == id; });
    v1::ScanHeader* scan = job.header.add_scans();
    if (match != from_job.end()) {
      *scan = *match;
      from_job.erase(match);
    }
    scan->set_scan_id(id);
    // A file's sensor origin (PCD VIEWPOINT, an E57 scan's pose) is in the file's frame and
    // units, as the header's camera_position is; the job file's value, when it has one, wins.
    // A file that describes its scans (E57) has one origin per scan.
    const size_t value = read.split.values.empty() ? 0 : read.split.values[k];
    const ScanMeta& meta = value < cloud.scans.size() ? cloud.scans[value] : cloud.scans.front();
    // A reader's positions, like its points, are relative to the cloud's origin.
    const std::optional<Eigen::Vector3d>& origin = meta.camera_position;
    if (origin && !scan->has_camera_position()) {
      SetVec3(*origin + cloud.origin, scan->mutable_camera_position());
    }
    // The points are sent relative to the origin the reader chose (double files far from zero).
    if (!cloud.origin.isZero(0)) SetVec3(cloud.origin, scan->mutable_points_offset());
    scan_files.push_back(file);
  }
}

// A LAS output keeps the grid of the first LAS read (the result comes back in the files' unit,
// so the grid still fits it); another file's points are written on that grid too.
void KeepFirstGrid(const std::string& file, const PointCloud& cloud, Job& job) {
  if (cloud.grid && !job.points.grid) {
    job.points.grid = cloud.grid;
  } else if (cloud.grid && (cloud.grid->scale != job.points.grid->scale ||
                            cloud.grid->offset != job.points.grid->offset)) {
    job.notes.push_back(absl::StrCat(file,
                                     ": its LAS scale and offset differ from the first LAS "
                                     "file's; a LAS output is written on the first's"));
  }
}

// Reads every scan argument and adds its scans to the header: one per file, in command-line
// order, or one per value of its scan column (named STEM#VALUE); a job-file scan with that name
// as its scan_id supplies the scan's metadata, and one that names no scan is an error.
// `scan_files`: the file each scan came from.
absl::StatusOr<std::vector<FileRead>> ReadScanFiles(const ParsedArgs& args,
                                                    const std::vector<io::ScanFormat>& formats,
                                                    Job& job,
                                                    std::vector<std::string>& scan_files) {
  std::vector<v1::ScanHeader> from_job(job.header.scans().begin(), job.header.scans().end());
  job.header.clear_scans();
  io::ReadOptions read_options;
  if (args.Has(CallFlags::kProfileGap)) {
    SCANPREP_ASSIGN_OR_RETURN(read_options.profile_gap, ParseLength(args, CallFlags::kProfileGap));
  }
  std::vector<FileRead> files;
  for (size_t f = 0; f < args.positional.size(); ++f) {
    const std::string& file = args.positional[f];
    FileRead& read = files.emplace_back();
    SCANPREP_ASSIGN_OR_RETURN(read.cloud,
                              ReadScanArgument(file, formats[f], job.notes, read_options));
    if (read.cloud.has_normals()) {
      job.notes.push_back(
          absl::StrCat(file, ": its normals are not sent (the service estimates its own)"));
    }
    read.split = SplitByScanColumn(read.cloud);
    read.first_scan = static_cast<uint32_t>(job.header.scans_size());
    AddFileScans(file, read, from_job, job, scan_files);
    KeepFirstGrid(file, read.cloud, job);
  }
  if (!from_job.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("the job file describes scan '",
                                                   from_job.front().scan_id(),
                                                   "' but no scan file has that stem"));
  }
  return files;
}

// Without --unit or a unit in the job file: E57 files are in metres, anything else is taken as
// millimetres, with a note.
void DefaultUnit(const ParsedArgs& args, const std::vector<io::ScanFormat>& formats, Job& job) {
  if (args.Has(CallFlags::kUnit) || job.header.unit() != v1::LENGTH_UNIT_UNSPECIFIED) return;
  auto is = [](io::ScanFormat format) {
    return [format](io::ScanFormat f) { return f == format; };
  };
  if (std::all_of(formats.begin(), formats.end(), is(io::ScanFormat::kE57))) {
    // E57 defines its coordinates in metres (ASTM E2807), so there is nothing to guess.
    job.header.set_unit(v1::LENGTH_UNIT_METRE);
    job.notes.push_back("E57 files are in metres by definition: the job's unit is metres");
    return;
  }
  // PCL's convention (REP 103) is metres, so a PCD file read as mm is likely 1000x too small.
  const bool pcd = std::any_of(formats.begin(), formats.end(), is(io::ScanFormat::kPcd));
  job.notes.push_back(
      absl::StrCat("no --unit and no unit in the job file: coordinates are taken "
                   "as millimetres",
                   pcd ? " (PCL writes PCD files in metres: pass --unit m if so)" : ""));
}

// The files' attributes (colour, a scanner's own fields) for the result, which the server
// returns with each point's upload position: one is kept when every file has it, of one type.
void JoinFileAttributes(const std::vector<std::string>& files, const std::vector<FileRead>& read,
                        Job& job) {
  std::vector<const std::vector<PointAttribute>*> parts;
  for (const FileRead& r : read) parts.push_back(&r.cloud.attributes);
  std::vector<std::vector<std::string>> left_out;
  job.points.attributes = JoinAttributes(parts, left_out);
  for (size_t s = 0; s < read.size(); ++s) {
    if (left_out[s].empty()) continue;
    job.notes.push_back(absl::StrCat(files[s], ": ", absl::StrJoin(left_out[s], ", "),
                                     " left out of the output (not in every file, of one type)"));
  }
  // Each returned point says where it was uploaded, so the output gets its attributes back.
  if (!job.points.attributes.empty()) job.header.set_return_source_index(true);
}

// Every file's points into the job's cloud, each point with the header index of its scan. The
// service wants an optional array in every chunk or none, so one is kept only when every file
// has it.
void JoinPoints(const std::vector<std::string>& files, const std::vector<FileRead>& read,
                Job& job) {
  bool scanlines = true, quality = true, intensity = true;
  for (const FileRead& r : read) {
    scanlines &= r.cloud.has_scanlines();
    quality &= !r.cloud.quality.empty();
    intensity &= !r.cloud.intensity.empty();
  }
  PointCloud& all = job.points;
  for (size_t s = 0; s < read.size(); ++s) {
    const PointCloud& c = read[s].cloud;
    if (c.has_scanlines() && !scanlines) {
      job.notes.push_back(absl::StrCat(files[s], ": scanlines dropped (not every file has them)"));
    }
    all.x.insert(all.x.end(), c.x.begin(), c.x.end());
    all.y.insert(all.y.end(), c.y.begin(), c.y.end());
    all.z.insert(all.z.end(), c.z.begin(), c.z.end());
    if (read[s].split.of_point.empty()) {
      all.scan.resize(all.x.size(), read[s].first_scan);
    } else {
      for (uint32_t k : read[s].split.of_point) all.scan.push_back(read[s].first_scan + k);
    }
    AppendOptional(scanlines, c.scanline, all.scanline);
    AppendOptional(quality, c.quality, all.quality);
    AppendOptional(intensity, c.intensity, all.intensity);
  }
  JoinFileAttributes(files, read, job);
}

}  // namespace

absl::StatusOr<std::vector<io::ScanFormat>> ScanArgumentFormats(const ParsedArgs& args) {
  const std::vector<std::string>& files = args.positional;
  if (files.empty()) return absl::InvalidArgumentError("no scan files given");
  if (std::count(files.begin(), files.end(), "-") > 1) {
    return absl::InvalidArgumentError("SCAN '-' (standard input) can be given once");
  }
  if (args.Has(CallFlags::kInputFormat) && std::count(files.begin(), files.end(), "-") == 0) {
    return absl::InvalidArgumentError("--input_format applies to SCAN '-' only; none was given");
  }
  std::vector<io::ScanFormat> formats;
  for (const std::string& file : files) {
    SCANPREP_ASSIGN_OR_RETURN(io::ScanFormat format, ScanArgumentFormat(file, args));
    formats.push_back(format);
  }
  return formats;
}

absl::Status CheckJobFlags(const ParsedArgs& args) {
  v1::JobHeader scratch;  // the flags' values parsed as BuildJob will, into a header thrown away
  SCANPREP_RETURN_IF_ERROR(ApplyOptionFlags(args, scratch));
  SCANPREP_RETURN_IF_ERROR(ParseSensorFlags(args).status());
  if (args.Has(CallFlags::kProfileGap)) return ParseLength(args, CallFlags::kProfileGap).status();
  return absl::OkStatus();
}

absl::StatusOr<Job> BuildJob(const ParsedArgs& args) {
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<io::ScanFormat> formats, ScanArgumentFormats(args));
  Job job;
  if (args.Has(CallFlags::kJob)) {
    SCANPREP_ASSIGN_OR_RETURN(job.header, ReadJobFile(args.Get(CallFlags::kJob)));
  }
  std::vector<std::string> scan_files;  // per scan: the file it came from
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<FileRead> read,
                            ReadScanFiles(args, formats, job, scan_files));
  if (args.Has(CallFlags::kConf)) {
    SCANPREP_RETURN_IF_ERROR(ApplyConf(args.Get(CallFlags::kConf), scan_files, job.header));
  }
  DefaultUnit(args, formats, job);
  SCANPREP_RETURN_IF_ERROR(ApplyOptionFlags(args, job.header));
  SCANPREP_RETURN_IF_ERROR(ApplySensorFlags(args, job.header));
  SetJobOrigin(job.header);
  JoinPoints(args.positional, read, job);
  return job;
}

v1::ScanHeader ScanHeaderFromMeta(const ScanMeta& meta) {
  v1::ScanHeader scan;
  scan.set_scan_id(meta.id);
  scan.set_sensor_id(meta.sensor_id);
  scan.set_points_unmeasured(meta.points_invalid);
  if (meta.camera_position) SetVec3(*meta.camera_position, scan.mutable_camera_position());
  if (meta.view_direction) SetVec3(*meta.view_direction, scan.mutable_view_direction());
  if (meta.projector_position) {
    SetVec3(*meta.projector_position, scan.mutable_projector_position());
  }
  if (meta.projector_direction) {
    SetVec3(*meta.projector_direction, scan.mutable_projector_direction());
  }
  scan.set_scanline_spacing(meta.scanline_spacing);
  scan.set_uncertainty(meta.uncertainty);
  scan.set_point_spacing(meta.point_spacing);
  return scan;
}

absl::Status CheckGeneratedJobFlags(const ParsedArgs& args) {
  for (const char* flag : {CallFlags::kUnit, CallFlags::kJob, CallFlags::kConf}) {
    if (args.Has(flag)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--", flag, " does not apply to a generated scan (millimetres, posed)"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<Job> BuildJobFromCloud(const ParsedArgs& args, PointCloud cloud) {
  SCANPREP_RETURN_IF_ERROR(CheckGeneratedJobFlags(args));
  Job job;
  job.header.set_unit(v1::LENGTH_UNIT_MILLIMETRE);
  job.header.set_scanner_kind(cloud.kind == ScannerKind::kLine ? v1::SCANNER_KIND_LINE
                                                               : v1::SCANNER_KIND_FLEXIBLE);
  for (const ScanMeta& meta : cloud.scans) {
    v1::ScanHeader* scan = job.header.add_scans();
    *scan = ScanHeaderFromMeta(meta);
    // Positions and points both relative to the cloud's origin; the server adds it back.
    if (!cloud.origin.isZero(0)) {
      if (meta.camera_position) {
        SetVec3(*meta.camera_position + cloud.origin, scan->mutable_camera_position());
      }
      if (meta.projector_position) {
        SetVec3(*meta.projector_position + cloud.origin, scan->mutable_projector_position());
      }
      SetVec3(cloud.origin, scan->mutable_points_offset());
    }
  }
  SetJobOrigin(job.header);
  SCANPREP_RETURN_IF_ERROR(ApplyOptionFlags(args, job.header));
  SCANPREP_RETURN_IF_ERROR(ApplySensorFlags(args, job.header));
  job.points = std::move(cloud);
  return job;
}

}  // namespace scanprep::client
