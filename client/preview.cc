// SPDX-License-Identifier: Apache-2.0
#include "client/preview.h"

#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include <Eigen/Eigenvalues>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"

namespace scanprep::client {
namespace {

constexpr int kPanelWidth = 640, kPanelHeight = 480, kLegendHeight = 96, kMargin = 24;
constexpr int kTitleHeight = 28;
constexpr Rgb kText{30, 30, 30};

// A 5 x 7 pixel font for the legend's capitals, digits and a few signs: each glyph is seven
// rows of five bits, the leftmost pixel in bit 4.
struct Glyph {
  char c;
  std::array<uint8_t, 7> rows;
};
constexpr Glyph kFont[] = {
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'.', {0, 0, 0, 0, 0, 0x0C, 0x0C}},
    {'-', {0, 0, 0, 0x1F, 0, 0, 0}},
    {':', {0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0}},
    {'/', {0x01, 0x01, 0x02, 0x04, 0x08, 0x10, 0x10}},
    {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
    {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
    {'+', {0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0}},
    {'A', {0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {'B', {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E}},
    {'C', {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}},
    {'D', {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C}},
    {'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}},
    {'F', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}},
    {'G', {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}},
    {'H', {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {'I', {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}},
    {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}},
    {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F}},
    {'M', {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}},
    {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
    {'O', {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
    {'P', {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}},
    {'Q', {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}},
    {'R', {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11}},
    {'S', {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}},
    {'T', {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
    {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}},
    {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}},
    {'X', {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11}},
    {'Y', {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}},
    {'Z', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F}},
};

// Writes `text` (upper-cased; characters without a glyph are spaces) with its top-left corner at
// (x, y), each font pixel `scale` pixels square.
void DrawText(Image& image, int x, int y, const std::string& text, int scale = 2) {
  for (char c : absl::AsciiStrToUpper(text)) {
    for (const Glyph& g : kFont) {
      if (g.c != c) continue;
      for (int row = 0; row < 7; ++row) {
        for (int col = 0; col < 5; ++col) {
          if (((g.rows[row] >> (4 - col)) & 1) == 0) continue;
          for (int dy = 0; dy < scale; ++dy) {
            for (int dx = 0; dx < scale; ++dx) {
              const int px = x + col * scale + dx, py = y + row * scale + dy;
              if (px >= 0 && py >= 0 && px < image.width && py < image.height) {
                image.set(px, py, kText);
              }
            }
          }
        }
      }
    }
    x += 6 * scale;
  }
}

void FillRect(Image& image, int x, int y, int w, int h, Rgb c) {
  for (int py = std::max(0, y); py < std::min(image.height, y + h); ++py) {
    for (int px = std::max(0, x); px < std::min(image.width, x + w); ++px) image.set(px, py, c);
  }
}

Rgb Scaled(Rgb c, double f) {
  auto s = [f](uint8_t v) { return static_cast<uint8_t>(std::clamp(v * f, 0.0, 255.0)); };
  return {s(c.r), s(c.g), s(c.b)};
}

// Screen coordinates of the panels: both share one mapping, so the panels line up.
struct Projection {
  Eigen::Vector3d right, up, direction;
  double scale = 1, cx = 0, cy = 0;  // pixels per unit, centre of the cloud on screen
  int splat = 1;                     // pixels per point side
  Eigen::Vector2d Screen(const Eigen::Vector3d& p) const {
    return {kPanelWidth / 2.0 + scale * (p.dot(right) - cx),
            kTitleHeight + (kPanelHeight - kTitleHeight) / 2.0 - scale * (p.dot(up) - cy)};
  }
};

// The range of `values` without its outermost 0.5 % at each end, so a stray far point does not
// shrink the picture of everything else to a dot (it is drawn off the panel, clipped).
std::pair<double, double> CoreRange(std::vector<double>& values) {
  const size_t n = values.size(), cut = n >= 200 ? n / 200 : 0;
  std::nth_element(values.begin(), values.begin() + cut, values.end());
  const double lo = values[cut];
  std::nth_element(values.begin(), values.end() - 1 - cut, values.end());
  return {lo, values[n - 1 - cut]};
}

Projection Fit(const PointCloud& cloud, const PreviewView& view) {
  Projection p{.right = view.direction.cross(view.up), .up = view.up, .direction = view.direction};
  if (cloud.size() == 0) return p;
  std::vector<double> xs(cloud.size()), ys(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d q = cloud.point(i).cast<double>();
    xs[i] = q.dot(p.right), ys[i] = q.dot(p.up);
  }
  const auto [x0, x1] = CoreRange(xs);
  const auto [y0, y1] = CoreRange(ys);
  const double w = std::max(x1 - x0, 1e-12), h = std::max(y1 - y0, 1e-12);
  p.scale =
      std::min((kPanelWidth - 2 * kMargin) / w, (kPanelHeight - kTitleHeight - 2 * kMargin) / h);
  p.cx = (x0 + x1) / 2, p.cy = (y0 + y1) / 2;
  // Splats about the points' spacing on screen, so a surface looks closed but detail stays.
  const double area = w * h * p.scale * p.scale;
  p.splat = std::clamp(static_cast<int>(std::sqrt(area / cloud.size())), 1, 3);
  return p;
}

// One panel: points drawn nearest-first through a depth buffer.
class Panel {
 public:
  Panel(Image& image, int x0, const Projection& projection)
      : image_(image),
        x0_(x0),
        projection_(projection),
        depth_(static_cast<size_t>(kPanelWidth) * kPanelHeight,
               std::numeric_limits<double>::infinity()) {}

  // `on_top` points ignore the depth buffer (removed points must show wherever they are).
  void Draw(const Eigen::Vector3d& p, Rgb colour, bool on_top = false) {
    const Eigen::Vector2d s = projection_.Screen(p);
    const double depth =
        on_top ? -std::numeric_limits<double>::infinity() : p.dot(projection_.direction);
    // Off the panel (a stray far point, outside the fitted core): nothing to draw, and no
    // coordinate too large for an int.
    if (!(s.x() > -8 && s.x() < kPanelWidth + 8 && s.y() > -8 && s.y() < kPanelHeight + 8)) return;
    const int sx = static_cast<int>(std::floor(s.x())), sy = static_cast<int>(std::floor(s.y()));
    for (int dy = 0; dy < projection_.splat; ++dy) {
      for (int dx = 0; dx < projection_.splat; ++dx) {
        const int x = sx + dx, y = sy + dy;
        if (x < 0 || y < kTitleHeight || x >= kPanelWidth || y >= kPanelHeight) continue;
        double& d = depth_[static_cast<size_t>(y) * kPanelWidth + x];
        if (!on_top && depth >= d) continue;
        d = depth;
        image_.set(x0_ + x, y, colour);
      }
    }
  }

 private:
  Image& image_;
  int x0_;
  const Projection& projection_;
  std::vector<double> depth_;
};

// Grey lit from the camera when the point has a normal, so the shape reads.
double Lambert(const PointCloud& normals, size_t i, const Eigen::Vector3d& direction) {
  if (!normals.has_normals() || (normals.flags[i] & kNormalInvalid) != 0) return 0.8;
  return 0.45 + 0.55 * std::abs(normals.normal(i).cast<double>().dot(direction));
}

Rgb RemovedColour(uint8_t flags) {
  if (flags & kRemovedOutlier) return kOutlierColour;
  if (flags & kRemovedMerge) return kMergeColour;
  return kSimplifyColour;
}

// Removed points after the kept ones, the rarest reasons last so they stay visible.
void DrawRemoved(Panel& panel, const PointCloud& geometry, const PointCloud& flagged) {
  for (uint8_t reason :
       {uint8_t{kRemovedSimplify}, uint8_t{kRemovedMerge}, uint8_t{kRemovedOutlier}}) {
    for (size_t i = 0; i < flagged.size(); ++i) {
      if (flagged.removed(i) && RemovedColour(flagged.flags[i]) == RemovedColour(reason)) {
        panel.Draw(geometry.point(i).cast<double>(), RemovedColour(reason), true);
      }
    }
  }
}

void DrawLegend(Image& image, const PreviewPanels& panels, const PreviewView& view,
                double max_displacement) {
  const int y = kPanelHeight + 12;
  int x = 16;
  const std::pair<Rgb, const char*> keys[] = {{kOutlierColour, "outlier"},
                                              {kMergeColour, "merged"},
                                              {kSimplifyColour, "simplified"},
                                              {kEdgeColour, "edge"}};
  for (const auto& [colour, name] : keys) {
    FillRect(image, x, y, 14, 14, colour);
    DrawText(image, x + 20, y, name);
    x += 20 + 12 * static_cast<int>(std::string(name).size()) + 18;
  }
  DrawText(image, 16, y + 28, absl::StrCat("view: ", view.source));
  if (panels.input == nullptr || panels.displacement.empty()) return;
  // The scale bar: 256 steps of the colour map, 0 at its left end, the largest move at its right.
  const int bar_x = kPanelWidth + 16, bar_y = y + 28;
  DrawText(image, bar_x, y, "smoothing displacement");
  for (int k = 0; k < 256; ++k)
    FillRect(image, bar_x + k, bar_y, 1, 16, DisplacementColour(k / 255.0));
  DrawText(image, bar_x, bar_y + 22, "0");
  DrawText(image, bar_x + 256 + 10, bar_y + 2,
           absl::StrFormat("%.3g %s", max_displacement, panels.unit));
}

}  // namespace

Rgb DisplacementColour(double fraction) {
  const double f = std::clamp(fraction, 0.0, 1.0);
  // Blue through teal to yellow: ordered in lightness, readable by colour-blind viewers.
  const Eigen::Vector3d stops[] = {{40, 60, 200}, {30, 170, 150}, {250, 220, 30}};
  const double t = 2 * f;
  const int k = std::min(1, static_cast<int>(t));
  const Eigen::Vector3d c = stops[k] + (t - k) * (stops[k + 1] - stops[k]);
  return {static_cast<uint8_t>(std::lround(c.x())), static_cast<uint8_t>(std::lround(c.y())),
          static_cast<uint8_t>(std::lround(c.z()))};
}

PreviewView ChooseView(const PointCloud& cloud, const ScanMeta& scan) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < cloud.size(); ++i) mean += cloud.point(i).cast<double>();
  mean /= std::max<size_t>(1, cloud.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d d = cloud.point(i).cast<double>() - mean;
    covariance += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(covariance);
  PreviewView view;
  if (scan.camera_position && (mean - *scan.camera_position).norm() > 0) {
    view.direction = (mean - *scan.camera_position).normalized();
    view.source = "scanner";
  } else if (scan.view_direction && scan.view_direction->norm() > 0) {
    view.direction =
        -scan.view_direction->normalized();  // it points from the surface to the sensor
    view.source = "scanner";
  } else {
    view.direction = pca.eigenvectors().col(0);  // the thinnest direction
    view.source = "automatic";
    if (cloud.has_normals()) {
      double facing = 0;
      for (size_t i = 0; i < cloud.size(); ++i) {
        if (std::isfinite(cloud.nx[i]))
          facing += cloud.normal(i).cast<double>().dot(view.direction);
      }
      if (facing > 0) view.direction = -view.direction;  // normals point at the camera
    }
  }
  // Up: the longest direction, made perpendicular to the view.
  Eigen::Vector3d up = pca.eigenvectors().col(2);
  up -= up.dot(view.direction) * view.direction;
  if (up.norm() < 1e-9) up = view.direction.unitOrthogonal();
  view.up = up.normalized();
  return view;
}

Image RenderPreview(const PreviewPanels& panels, const PreviewView& view) {
  const bool pair = panels.input != nullptr;
  Image image{.width = pair ? 2 * kPanelWidth : kPanelWidth,
              .height = kPanelHeight + kLegendHeight};
  image.rgb.assign(static_cast<size_t>(image.width) * image.height * 3, 255);
  const PointCloud& result = *panels.result;
  const Projection projection = Fit(pair ? *panels.input : result, view);
  double max_displacement = 0;
  for (float d : panels.displacement) max_displacement = std::max<double>(max_displacement, d);
  const bool displaced = pair && !panels.displacement.empty() && max_displacement > 0;

  if (pair) {
    // The input: its points lit grey, then the ones the service removed in their reason's colour.
    Panel left(image, 0, projection);
    const PointCloud& input = *panels.input;
    for (size_t i = 0; i < input.size(); ++i) {
      const double shade = i < result.size() ? Lambert(result, i, view.direction) : 0.8;
      left.Draw(input.point(i).cast<double>(), Scaled({235, 235, 235}, shade));
    }
    if (input.size() == result.size()) DrawRemoved(left, input, result);
    DrawText(image, 12, 8, absl::StrCat("input: ", input.size(), " points"));
  }
  // The result: kept points, coloured by how far smoothing moved them, edges marked.
  Panel right(image, pair ? kPanelWidth : 0, projection);
  size_t kept = 0;
  for (size_t i = 0; i < result.size(); ++i) {
    if (result.removed(i)) continue;
    ++kept;
    const double shade = Lambert(result, i, view.direction);
    Rgb colour = displaced ? DisplacementColour(panels.displacement[i] / max_displacement)
                           : Rgb{235, 235, 235};
    if (result.flags[i] & kEdge) colour = kEdgeColour;
    right.Draw(result.point(i).cast<double>(), Scaled(colour, 0.55 + 0.45 * shade));
  }
  if (!pair) DrawRemoved(right, result, result);
  DrawText(image, (pair ? kPanelWidth : 0) + 12, 8,
           absl::StrCat(pair ? "result: " : "", kept, " points kept of ", result.size()));
  DrawLegend(image, panels, view, max_displacement);
  return image;
}

absl::Status CheckPreviewPath(const std::filesystem::path& path) {
  if (absl::AsciiStrToLower(path.extension().string()) == ".png") return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(path.string(), ": cannot write a preview as '", path.extension().string(),
                   "' (previews are written as PNG: give a .png file)"));
}

absl::Status WritePng(const std::filesystem::path& path, const Image& image) {
  SCANPREP_RETURN_IF_ERROR(CheckPreviewPath(path));
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (file == nullptr) return absl::UnavailableError(absl::StrCat("cannot create ", path.string()));
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return absl::ResourceExhaustedError("cannot start a PNG");
  }
  if (setjmp(png_jmpbuf(png))) {  // libpng reports its errors by jumping here
    png_destroy_write_struct(&png, &info);
    return absl::UnavailableError(absl::StrCat("cannot write the PNG ", path.string()));
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    png_write_row(png, image.rgb.data() + 3 * static_cast<size_t>(y) * image.width);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(file.get()) != 0) {
    return absl::UnavailableError(absl::StrCat("cannot write the PNG ", path.string()));
  }
  return absl::OkStatus();
}

}  // namespace scanprep::client
