// SPDX-License-Identifier: Apache-2.0
// Issue 40, item 7: a file's colour and other per-point fields were dropped by `scanprep
// process`. Now they come back for the points that survive, through the real CLI and server.
// Ground truth is in the file: each point's colour spells its own index and its "temperature" is
// a quarter of it, so an output point's fields must name the input point it sits on, and the
// spike, which the outlier stage removes, must be gone with its colour.
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "core/io/scan_file.h"
#include "tests/server/server_process.h"
#include "tests/support/run_command.h"

namespace scanprep::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kSide = 40;
constexpr int kSpike = 20 * kSide + 20;  // in the middle of the plate, 5 mm above it

Eigen::Vector3f InputPoint(int i) {
  return {0.5f * static_cast<float>(i % kSide), 0.5f * static_cast<float>(i / kSide),
          i == kSpike ? 5.f : 0.f};
}

class CliAttributes : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("attributes_" + std::to_string(getpid()));
    fs::create_directories(dir_);
    std::ofstream ply(at("plate.ply"));
    ply << "ply\nformat ascii 1.0\nelement vertex " << kSide * kSide
        << "\nproperty float x\nproperty float y\nproperty float z\nproperty int row\n"
           "property uchar red\nproperty uchar green\nproperty uchar blue\n"
           "property float temperature\nend_header\n";
    for (int i = 0; i < kSide * kSide; ++i) {
      const Eigen::Vector3f p = InputPoint(i);
      ply << p.x() << " " << p.y() << " " << p.z() << " " << i / kSide << " " << i % 256 << " "
          << i / 256 << " 0 " << 0.25 * i << "\n";
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string at(const std::string& name) const { return (dir_ / name).string(); }

  CommandResult Process(const ServerProcess& server, const std::string& out) const {
    return RunCommand(std::string(SCANPREP_CLI_BINARY) + " process " + at("plate.ply") + " -o " +
                      at(out) + " --unit mm --scanline_spacing 0.5 --progress off --server " +
                      server.target());
  }

  fs::path dir_;
};

const PointAttribute* Find(const PointCloud& cloud, const std::string& name) {
  for (const PointAttribute& a : cloud.attributes) {
    if (a.name == name) return &a;
  }
  return nullptr;
}

// Each written point's colour names an input point: it sits there, its temperature (where the
// format keeps it) is that point's, and the spike is not among them. LAS keeps 8-bit colour as 16
// bits, scaled by 256 as its specification asks.
void ExpectFieldsOfTheirOwnPoints(const std::string& path, bool las = false) {
  std::vector<std::string> warnings;
  auto out = io::ReadScanFile(path, warnings);
  ASSERT_TRUE(out.ok()) << out.status();
  const PointAttribute *red = Find(*out, "red"), *green = Find(*out, "green"),
                       *temperature = Find(*out, "temperature");
  ASSERT_TRUE(red && green) << path;
  ASSERT_EQ(temperature != nullptr, !las) << path;
  EXPECT_EQ(red->type, las ? AttributeType::kUint16 : AttributeType::kUint8);
  if (!las) EXPECT_EQ(temperature->type, AttributeType::kFloat32);
  const double scale = las ? 256 : 1;
  ASSERT_GT(out->size(), 100u);  // the flat plate is thinned (simplification), not emptied
  for (size_t k = 0; k < out->size(); ++k) {
    const int i = static_cast<int>((red->Value(k) + 256 * green->Value(k)) / scale);
    ASSERT_NE(i, kSpike) << "the removed spike's colour came back";
    if (!las) EXPECT_EQ(temperature->Value(k), 0.25 * i) << k;
    // Smoothing moves a point of the flat plate along its normal (z), and not far; LAS holds
    // coordinates on a 1 µm grid.
    EXPECT_NEAR(out->x[k] + out->origin.x(), InputPoint(i).x(), las ? 5e-4 : 0) << k;
    EXPECT_NEAR(out->y[k] + out->origin.y(), InputPoint(i).y(), las ? 5e-4 : 0) << k;
    EXPECT_NEAR(out->z[k] + out->origin.z(), InputPoint(i).z(), 0.05) << k;
  }
}

TEST_F(CliAttributes, ColourAndScalarsComeBackForTheSurvivorsInPlyPcdAndXyz) {
  ServerProcess server;
  ASSERT_GT(server.port(), 0);
  for (const char* out : {"out.ply", "out.pcd", "out.xyz"}) {
    const CommandResult r = Process(server, out);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_THAT(r.output, ::testing::Not(HasSubstr("left out")));
    ExpectFieldsOfTheirOwnPoints(at(out));
  }
  // LAS keeps the colour and names the field it has no place for rather than dropping it.
  const CommandResult las = Process(server, "out.las");
  ASSERT_EQ(las.exit_code, 0) << las.output;
  EXPECT_THAT(las.output, HasSubstr("note: temperature left out of the output"));
  ExpectFieldsOfTheirOwnPoints(at("out.las"), true);
  EXPECT_EQ(server.Terminate(), 0);
}

}  // namespace
}  // namespace scanprep::testing
