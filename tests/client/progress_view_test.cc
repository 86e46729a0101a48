// SPDX-License-Identifier: Apache-2.0
// The CLI's progress display, on a fake clock: the job's percentage with elapsed time and ETA,
// the running stage's place in the plan, and plain lines only when something a reader needs
// changed (a new phase or stage, a quarter of it, or 10 s of silence).
#include "client/progress_view.h"

#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/strings/str_split.h"

namespace scanprep::testing {
namespace {

namespace v1 = ::scanprep::v1;
using client::ProgressMode;
using client::ProgressView;
using ::testing::ElementsAre;

v1::Progress Stage(const std::string& name, int index, int count, double fraction, double job) {
  v1::Progress p;
  p.set_phase(v1::Progress::PHASE_PROCESSING);
  p.set_stage(name);
  p.set_stage_index(index);
  p.set_stage_count(count);
  p.set_fraction(fraction);
  p.set_job_fraction(job);
  return p;
}

v1::Progress Transfer(v1::Progress::Phase phase, double fraction, uint64_t points) {
  v1::Progress p;
  p.set_phase(phase);
  p.set_fraction(fraction);
  p.set_points(points);
  return p;
}

struct FakeClock {
  absl::Time now = absl::UnixEpoch();
  ProgressView::Clock fn() {
    return [this] { return now; };
  }
};

std::vector<std::string> Lines(const std::string& text) {
  return absl::StrSplit(text, '\n', absl::SkipEmpty());
}

TEST(ProgressView, PlainLinesAtEachStartAndQuarterWithElapsedAndEta) {
  FakeClock clock;
  std::ostringstream out;
  ProgressView view(out, ProgressMode::kPlain, clock.fn());
  view.Update(Transfer(v1::Progress::PHASE_UPLOAD, 0.1, 100));
  view.Update(Transfer(v1::Progress::PHASE_UPLOAD, 0.2, 200));  // same quarter: no line
  clock.now += absl::Seconds(1);
  view.Update(Transfer(v1::Progress::PHASE_UPLOAD, 1.0, 1000));
  view.Update(Stage("neighbourhoods", 0, 2, 0, 0));  // processing starts at 1 s
  clock.now += absl::Seconds(2);
  view.Update(Stage("neighbourhoods", 0, 2, 0.1, 0.05));
  view.Update(Stage("neighbourhoods", 0, 2, 0.6, 0.2));  // skips 25 %: one line at 60 %
  clock.now += absl::Seconds(2);
  view.Update(Stage("normals", 1, 2, 0.0, 0.25));  // 4 s of processing for a quarter: 12 s left
  clock.now += absl::Seconds(11);                  // silent for 10 s: a line all the same
  view.Update(Stage("normals", 1, 2, 0.05, 0.5));
  view.Update(Transfer(v1::Progress::PHASE_DOWNLOAD, 0.5, 500));
  EXPECT_THAT(Lines(out.str()),
              ElementsAre("[   0.0 s] upload      10%  100 points",
                          "[   1.0 s] upload     100%  1000 points",
                          "[   1.0 s] processing   0%  ETA ...  [1/2] neighbourhoods 0%",
                          "[   3.0 s] processing  20%  ETA 8.0 s  [1/2] neighbourhoods 60%",
                          "[   5.0 s] processing  25%  ETA 12.0 s  [2/2] normals 0%",
                          "[  16.0 s] processing  50%  ETA 15.0 s  [2/2] normals 5%",
                          "[  16.0 s] download    50%  500 points"));
}

// The control for the quarters: the same stage reported every 1 % for 5 s draws 4 lines, not 100.
TEST(ProgressView, PlainModeDoesNotPrintEveryEvent) {
  FakeClock clock;
  std::ostringstream out;
  ProgressView view(out, ProgressMode::kPlain, clock.fn());
  for (int i = 0; i < 100; ++i) {
    view.Update(Stage("smoothing", 5, 7, i / 100.0, 0.7));
    clock.now += absl::Milliseconds(50);
  }
  EXPECT_EQ(Lines(out.str()).size(), 4u) << out.str();
}

TEST(ProgressView, LiveModeRedrawsOneLineAndClearsIt) {
  FakeClock clock;
  std::ostringstream out;
  ProgressView view(out, ProgressMode::kLive, clock.fn());
  view.Update(Stage("normals", 2, 7, 0.5, 0.3));
  clock.now += absl::Seconds(1.5);
  view.Update(Stage("normals", 2, 7, 0.52, 0.31));
  view.Done();
  EXPECT_EQ(out.str(),
            "\r\033[Kprocessing  30%  ETA ...  [3/7] normals 50%  elapsed 0.0 s"
            "\r\033[Kprocessing  31%  ETA 3.3 s  [3/7] normals 52%  elapsed 1.5 s"
            "\r\033[K");
}

TEST(ProgressView, OffPrintsNothing) {
  std::ostringstream out;
  ProgressView view(out, ProgressMode::kOff);
  view.Update(Stage("normals", 2, 7, 0.5, 0.3));
  view.Done();
  EXPECT_EQ(out.str(), "");
}

TEST(ProgressView, ModeFromTheFlagAndTheTerminal) {
  EXPECT_EQ(*client::ParseProgressMode("auto", true), ProgressMode::kLive);
  EXPECT_EQ(*client::ParseProgressMode("auto", false), ProgressMode::kPlain);
  EXPECT_EQ(*client::ParseProgressMode("plain", true), ProgressMode::kPlain);
  EXPECT_EQ(*client::ParseProgressMode("live", false), ProgressMode::kLive);
  EXPECT_EQ(*client::ParseProgressMode("off", true), ProgressMode::kOff);
  EXPECT_EQ(client::ParseProgressMode("loud", true).status().message(),
            "--progress loud: expected auto, live, plain or off");
}

}  // namespace
}  // namespace scanprep::testing
