// SPDX-License-Identifier: Apache-2.0
// Preview pictures checked by their pixels on a synthetic scene whose every colour is known: a
// flat plate seen face-on (its normals face the camera, so shading is exactly 1), with points
// removed for each reason, an edge point and one point moved by smoothing.
#include "client/preview.h"

#include <png.h>

#include <filesystem>

#include <gtest/gtest.h>

namespace scanprep::client {
namespace {

constexpr int kPanel = 640, kPanelHeight = 480;

// A 60 x 40 plate in the z = 0 plane, 1 unit apart, normals +z; point `index(x, y)`.
struct Scene {
  PointCloud input, result;
  std::vector<float> displacement;
  static size_t index(int x, int y) { return static_cast<size_t>(y) * 60 + x; }
};

Scene Plate() {
  Scene s;
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 60; ++x) {
      s.input.x.push_back(x), s.input.y.push_back(y), s.input.z.push_back(0);
    }
  }
  s.input.FinishLoading();
  s.input.scans.assign(1, ScanMeta{.id = "plate"});
  s.result = s.input;
  s.result.nx.assign(s.result.size(), 0), s.result.ny.assign(s.result.size(), 0);
  s.result.nz.assign(s.result.size(), 1);
  s.result.flags[Scene::index(5, 5)] = kRemovedOutlier;
  s.result.flags[Scene::index(50, 30)] = kRemovedMerge;
  for (int x = 20; x < 40; ++x) s.result.flags[Scene::index(x, 20)] = kRemovedSimplify;
  s.result.flags[Scene::index(30, 10)] = kEdge;
  s.displacement.assign(s.result.size(), 0);
  s.displacement[Scene::index(10, 30)] = 0.05f;  // the largest move: the top of the scale
  return s;
}

// Pixels of `colour` in the columns [x0, x1) above the legend.
int Count(const Image& image, Rgb colour, int x0, int x1, int y0 = 0, int y1 = kPanelHeight) {
  int n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) n += image.at(x, y) == colour;
  }
  return n;
}

TEST(Preview, InputAndResultSideBySideInTheirColours) {
  const Scene s = Plate();
  const PreviewPanels panels{
      .input = &s.input, .result = &s.result, .displacement = s.displacement, .unit = "mm"};
  const PreviewView view = ChooseView(s.result, s.result.scans[0]);
  EXPECT_EQ(view.source, "automatic");
  EXPECT_NEAR(view.direction.z(), -1, 1e-9);  // face-on, looking against the normals
  const Image image = RenderPreview(panels, view);
  ASSERT_EQ(image.width, 2 * kPanel);
  // The input panel shows each removed point in its reason's colour, the result panel none.
  EXPECT_GT(Count(image, kOutlierColour, 0, kPanel), 0);
  EXPECT_GT(Count(image, kMergeColour, 0, kPanel), 0);
  EXPECT_GT(Count(image, kSimplifyColour, 0, kPanel), 0);
  EXPECT_EQ(Count(image, kOutlierColour, kPanel, 2 * kPanel), 0);
  EXPECT_EQ(Count(image, kSimplifyColour, kPanel, 2 * kPanel), 0);
  // Twenty simplified points against one outlier: the colours' areas keep that ratio.
  EXPECT_NEAR(Count(image, kSimplifyColour, 0, kPanel),
              20 * Count(image, kOutlierColour, 0, kPanel), 1);
  // The result: the edge point marked, the moved point at the top of the colour map, the rest
  // at its bottom (shading is exactly 1 face-on, so the colours are exact).
  EXPECT_GT(Count(image, kEdgeColour, kPanel, 2 * kPanel), 0);
  EXPECT_EQ(Count(image, kEdgeColour, 0, kPanel), 0);
  const int top = Count(image, DisplacementColour(1), kPanel, 2 * kPanel);
  EXPECT_GT(top, 0);
  EXPECT_EQ(top, Count(image, kOutlierColour, 0, kPanel));  // one point each, same splat
  EXPECT_GT(Count(image, DisplacementColour(0), kPanel, 2 * kPanel), 1000);
  // The scale bar in the legend runs from the bottom to the top colour.
  EXPECT_GT(Count(image, DisplacementColour(0), kPanel, 2 * kPanel, kPanelHeight, image.height), 0);
  EXPECT_GT(Count(image, DisplacementColour(1), kPanel, 2 * kPanel, kPanelHeight, image.height), 0);
  // Deterministic: the same scene gives the same bytes.
  EXPECT_EQ(RenderPreview(panels, view).rgb, image.rgb);
}

// Control: without removed points, edges or movement, none of those colours appear.
TEST(Preview, AnUntouchedCloudHasNoneOfTheMarkingColours) {
  Scene s = Plate();
  s.result.flags.assign(s.result.size(), 0);
  s.displacement.assign(s.result.size(), 0);
  const PreviewPanels panels{
      .input = &s.input, .result = &s.result, .displacement = s.displacement};
  const Image image = RenderPreview(panels, ChooseView(s.result, s.result.scans[0]));
  for (Rgb c : {kOutlierColour, kMergeColour, kSimplifyColour, kEdgeColour}) {
    EXPECT_EQ(Count(image, c, 0, 2 * kPanel), 0);
  }
  EXPECT_EQ(Count(image, DisplacementColour(1), 0, 2 * kPanel), 0);  // no scale without a move
}

// `scanprep preview` of a written result: one panel, removed points by their flags, and the
// scanner's view when the scan has a camera (here beside the plate, looking along +x).
TEST(Preview, OneCloudFromItsScannersView) {
  Scene s = Plate();
  s.result.scans[0].camera_position = Eigen::Vector3d(-100, 20, 0);
  s.result.nx.clear(), s.result.ny.clear(), s.result.nz.clear();
  const PreviewView view = ChooseView(s.result, s.result.scans[0]);
  EXPECT_EQ(view.source, "scanner");
  EXPECT_NEAR(view.direction.x(), 1, 0.01);
  const Image image = RenderPreview({.result = &s.result}, view);
  ASSERT_EQ(image.width, kPanel);
  EXPECT_GT(Count(image, kOutlierColour, 0, kPanel), 0);
  EXPECT_GT(Count(image, kMergeColour, 0, kPanel), 0);
}

// A stray point 10^8 units away (a far-away reflection) is left off the picture instead of
// shrinking the plate to a dot: the plate covers as many pixels as without it (control).
TEST(Preview, AFarAwayPointDoesNotShrinkThePicture) {
  const Scene s = Plate();
  const Image plain = RenderPreview({.result = &s.result}, ChooseView(s.result, s.result.scans[0]));
  Scene far = Plate();
  for (PointCloud* c : {&far.input, &far.result}) {
    c->x.push_back(1e8f), c->y.push_back(0), c->z.push_back(0), c->scan.push_back(0);
    c->flags.push_back(0);
  }
  far.result.nx.push_back(0), far.result.ny.push_back(0), far.result.nz.push_back(1);
  const Image image =
      RenderPreview({.result = &far.result}, ChooseView(far.result, far.result.scans[0]));
  const Rgb grey = Rgb{235, 235, 235};
  const int drawn = Count(plain, grey, 0, kPanel);
  EXPECT_GT(drawn, 10'000);
  EXPECT_NEAR(Count(image, grey, 0, kPanel), drawn, drawn / 20);
}

TEST(Preview, PngReadsBackAsTheImage) {
  const Scene s = Plate();
  const Image image = RenderPreview({.result = &s.result}, ChooseView(s.result, s.result.scans[0]));
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / "preview.png";
  ASSERT_TRUE(WritePng(path, image).ok());
  png_image read{};
  read.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&read, path.c_str()));
  read.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(read));
  ASSERT_TRUE(png_image_finish_read(&read, nullptr, pixels.data(), 0, nullptr));
  EXPECT_EQ(static_cast<int>(read.width), image.width);
  EXPECT_EQ(static_cast<int>(read.height), image.height);
  EXPECT_EQ(pixels, image.rgb);
  EXPECT_FALSE(WritePng("/nonexistent/dir/x.png", image).ok());
}

}  // namespace
}  // namespace scanprep::client
