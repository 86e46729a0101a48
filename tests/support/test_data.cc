// SPDX-License-Identifier: Apache-2.0
#include "tests/support/test_data.h"

#include <algorithm>
#include <cstdlib>

#include "core/io/conf.h"
#include "core/io/ply.h"

namespace scanprep::testing {

std::filesystem::path SharedDataDir() {
  const char* env = std::getenv("SCANPREP_DATA_DIR");
  std::filesystem::path dir = env != nullptr ? env : SCANPREP_SHARED_DATA;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return {};
  return std::filesystem::weakly_canonical(dir, ec);
}

PointCloud LoadRangeScansMm(const std::filesystem::path& dir, const std::string& conf_name,
                            const std::vector<std::string>& names, double scanline_spacing_mm) {
  PointCloud all;
  auto conf = io::ReadConf(dir / conf_name);
  EXPECT_TRUE(conf.ok()) << conf.status();
  if (!conf.ok()) return all;
  for (const std::string& name : names) {
    const std::string file = name + ".ply";
    std::vector<std::string> ply_warnings;
    auto scan = io::ReadPly(dir / file, ply_warnings);
    EXPECT_TRUE(scan.ok()) << scan.status();
    auto entry = std::find_if(conf->begin(), conf->end(),
                              [&](const io::ConfEntry& e) { return e.file == file; });
    EXPECT_NE(entry, conf->end()) << file << " is not in " << conf_name;
    if (!scan.ok() || entry == conf->end()) return {};
    const uint32_t s = static_cast<uint32_t>(all.scans.size());
    all.scans.push_back(ScanMeta{.id = name,
                                 .view_direction = entry->pose.rotation * Eigen::Vector3d::UnitZ(),
                                 .scanline_spacing = scanline_spacing_mm,
                                 .uncertainty = 0.1});
    for (size_t i = 0; i < scan->size(); ++i) {
      const Eigen::Vector3d p = io::Apply(entry->pose, scan->point(i).cast<double>()) * 1000.0;
      all.x.push_back(static_cast<float>(p.x()));
      all.y.push_back(static_cast<float>(p.y()));
      all.z.push_back(static_cast<float>(p.z()));
      all.scan.push_back(s);
      all.scanline.push_back(scan->scanline[i]);
    }
  }
  all.kind = ScannerKind::kLine;
  all.flags.assign(all.size(), 0);
  return all;
}

}  // namespace scanprep::testing
