// SPDX-License-Identifier: Apache-2.0
// The ten Stanford bunny range scans as one job: each scan in its own frame with its bun.conf
// pose in the header, so the server does the registration.
#pragma once

#include <algorithm>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/base/point_cloud.h"
#include "core/io/conf.h"
#include "core/io/scan_file.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::testing {

namespace fs = std::filesystem;
namespace v1 = ::scanprep::v1;

inline const char* const kScans[] = {"bun000", "bun045", "bun090", "bun180",   "bun270",
                                     "bun315", "chin",   "top2",   "ear_back", "top3"};

struct BunnyJob {
  v1::JobHeader header;
  PointCloud points;  // metres, each scan in its own frame
};

inline BunnyJob LoadBunny(const fs::path& dir) {
  BunnyJob job;
  job.header.set_job_id("bunny");
  job.header.set_unit(v1::LENGTH_UNIT_METRE);
  auto conf = io::ReadConf(dir / "bun.conf");
  EXPECT_TRUE(conf.ok()) << conf.status();
  for (uint32_t s = 0; s < std::size(kScans); ++s) {
    const std::string file = std::string(kScans[s]) + ".ply";
    std::vector<std::string> warnings;
    auto cloud = io::ReadScanFile(dir / file, warnings);
    EXPECT_TRUE(cloud.ok()) << cloud.status();
    EXPECT_TRUE(warnings.empty()) << warnings.front();
    auto entry = std::find_if(conf->begin(), conf->end(),
                              [&](const io::ConfEntry& e) { return e.file == file; });
    EXPECT_NE(entry, conf->end()) << file;
    v1::ScanHeader* scan = job.header.add_scans();
    scan->set_scan_id(kScans[s]);
    const Eigen::Quaterniond& q = entry->pose.rotation;
    v1::Quaternion* rotation = scan->mutable_to_common()->mutable_rotation();
    rotation->set_x(q.x());
    rotation->set_y(q.y());
    rotation->set_z(q.z());
    rotation->set_w(q.w());
    v1::Vec3* t = scan->mutable_to_common()->mutable_translation();
    t->set_x(entry->pose.translation.x());
    t->set_y(entry->pose.translation.y());
    t->set_z(entry->pose.translation.z());
    PointCloud& all = job.points;
    all.x.insert(all.x.end(), cloud->x.begin(), cloud->x.end());
    all.y.insert(all.y.end(), cloud->y.begin(), cloud->y.end());
    all.z.insert(all.z.end(), cloud->z.begin(), cloud->z.end());
    all.scanline.insert(all.scanline.end(), cloud->scanline.begin(), cloud->scanline.end());
    all.scan.resize(all.x.size(), s);
  }
  return job;
}

}  // namespace scanprep::testing
