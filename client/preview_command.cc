// SPDX-License-Identifier: Apache-2.0
// `scanprep preview CLOUD -o OUT.png`: a picture of any scan file, its points coloured by the
// flags scanprep wrote (removed by reason, edges), from the scanner or an automatic view.
#include <iostream>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/preview.h"
#include "core/io/scan_file.h"

namespace scanprep::client {
namespace {

int RunPreview(const ParsedArgs& args) {
  if (args.positional.size() != 1) return FailUsage("preview", "give one scan file");
  if (!args.Has("out")) return FailUsage("preview", "-o OUT.png is required");
  if (absl::Status s = CheckPreviewPath(args.Get("out")); !s.ok()) {
    return FailUsage("preview", std::string(s.message()));
  }
  std::vector<std::string> warnings;
  auto cloud = io::ReadScanFile(args.positional.front(), warnings);
  if (!cloud.ok()) return Fail("preview", std::string(cloud.status().message()));
  for (const std::string& w : warnings) std::cerr << "note: " << w << "\n";
  const PreviewPanels panels{.result = &*cloud};
  const ScanMeta scanner = cloud->scans.empty() ? ScanMeta{} : cloud->scans.front();
  const Image image = RenderPreview(panels, ChooseView(*cloud, scanner));
  if (absl::Status s = WritePng(args.Get("out"), image); !s.ok()) {
    return Fail("preview", std::string(s.message()));
  }
  std::cout << "wrote " << image.width << " x " << image.height << " preview to " << args.Get("out")
            << "\n";
  return 0;
}

}  // namespace

Command PreviewCommand() {
  return Command{
      .name = "preview",
      .synopsis = "preview CLOUD -o OUT.png",
      .summary =
          "draw a scan file as PNG: removed points by reason, edges, from the scanner or "
          "an automatic view",
      .flags = {{"out", FlagSpec::kValue, "the PNG to write (required)", "o"}},
      .run = RunPreview,
  };
}

}  // namespace scanprep::client
