// SPDX-License-Identifier: Apache-2.0
// Pictures of what the service did, for metrology engineers: the input and the result side by
// side, seen from the scanner or along the cloud's thinnest direction, drawn into an RGB image
// without any graphics system (a point splatter with a depth buffer) and saved as PNG.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"

namespace scanprep::client {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // row-major, 3 bytes per pixel
  Rgb at(int x, int y) const {
    const size_t i = 3 * (static_cast<size_t>(y) * width + x);
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
  void set(int x, int y, Rgb c) {
    const size_t i = 3 * (static_cast<size_t>(y) * width + x);
    rgb[i] = c.r, rgb[i + 1] = c.g, rgb[i + 2] = c.b;
  }
};

// The colours a preview uses, so a reader of the picture (and a test) can tell them apart.
inline constexpr Rgb kBackground{255, 255, 255};
inline constexpr Rgb kOutlierColour{220, 30, 30};
inline constexpr Rgb kMergeColour{240, 160, 0};
inline constexpr Rgb kSimplifyColour{60, 110, 230};
inline constexpr Rgb kEdgeColour{200, 0, 200};
// Displacement colour map, 0 (blue) to the largest displacement (yellow).
Rgb DisplacementColour(double fraction);

struct PreviewView {
  Eigen::Vector3d direction;  // the way the camera looks, unit
  Eigen::Vector3d up;         // unit, perpendicular to direction
  std::string source;         // "scanner" or "automatic", printed in the legend
};

// From `scanner`'s camera_position toward the cloud's centre when it has one, against its
// view_direction (a line scanner's) when it has that, else along the cloud's thinnest principal
// direction (the side a scan is usually seen from), turned so the normals, when there are any,
// face the camera.
PreviewView ChooseView(const PointCloud& cloud, const ScanMeta& scanner);

struct PreviewPanels {
  // What was sent (in the result's frame: the scans' poses applied) and what came back with
  // every point, removed ones flagged, in the same order; `displacement` per result point (the
  // smoothing's move), empty when the input is not known point for point.
  const PointCloud* input = nullptr;
  const PointCloud* result = nullptr;
  std::vector<float> displacement;
  std::string unit = "mm";
};

// Two 640 x 480 panels (input with its removed points coloured by reason; result with edges
// highlighted and displacement coloured) and a legend strip: swatches, the view, and the
// displacement scale bar from 0 to its largest value. Deterministic for a given input.
// A single cloud (`result` only) gives one panel: its points by their flags.
Image RenderPreview(const PreviewPanels& panels, const PreviewView& view);

// OK for a path WritePng can write: a ".png" extension (any case). INVALID_ARGUMENT naming the
// extension and the one written otherwise, so "x.jpg" is refused rather than filled with PNG
// bytes a JPEG reader cannot open.
absl::Status CheckPreviewPath(const std::filesystem::path& path);

// PNG (RGB, 8 bits), after CheckPreviewPath.
absl::Status WritePng(const std::filesystem::path& path, const Image& image);

}  // namespace scanprep::client
