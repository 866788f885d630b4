// depowder-logcheck compare (the log replay regression's judge) on logs written here: a frame the
// tracker skipped counts against the coverage, not as a pose at the origin; a wrong pose fails.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <utility>

#include "depowder/part_pose_t.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/test_messages.hpp"

namespace {

using namespace depowder;

constexpr int kFrames = 50;
constexpr std::int64_t kUtime0 = 1'000'000;

// What depowder-tracker and depowder-progress publish for a cube sliding 1 mm a frame: PROGRESS
// for every frame, PART_POSE for all but `skipped`; frame `off` 5 mm away from the rest's path;
// after frame `corrupt` a PART_POSE whose part name has a length of 0 on the wire.
void writeOutput(const std::string& path, const std::set<int>& skipped = {}, int off = -1, int corrupt = -1,
                 bool progress = true) {
  lcm::LogFile log(path, "w");
  ASSERT_TRUE(log.good()) << path;
  for (int f = 0; f < kFrames; ++f) {
    const std::int64_t utime = kUtime0 + f * 33'333;
    Pose T = Pose::Identity();
    T.translation() << 0.001 * f + (f == off ? 0.005 : 0.0), 0.0, 0.05;
    if (!skipped.count(f)) {
      part_pose_t pose = testutil::trackingPose("cube", utime, T);
      pose.eta = 0.5;
      ASSERT_EQ(testutil::writeMessage(log, "PART_POSE", pose, utime + 5'000), 0);
    }
    if (progress) {
      ASSERT_EQ(testutil::writeMessage(log, "PROGRESS", testutil::vacuumProgress("cube", utime, T, 0.5), utime + 6'000),
                0);
    }
    if (f == corrupt) {
      std::vector<std::uint8_t> data = testutil::encoded(testutil::trackingPose("cube", utime, T));
      std::fill(data.begin() + 16, data.begin() + 20, 0);  // after the hash and utime: part's length
      ASSERT_EQ(testutil::writeBytes(log, "PART_POSE", std::move(data), utime + 7'000), 0);
    }
  }
}

class LogCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    writeOutput(path("golden.lcmlog"));
    std::string out;
    ASSERT_EQ(run({"record", path("golden.lcmlog"), path("expected.txt")}, &out), 0) << out;
  }
  std::string path(const std::string& file) const { return logcheck_.dir() + "/" + file; }
  // Runs depowder-logcheck to its end: its exit status, and what it printed in `out`.
  int run(const std::vector<std::string>& args, std::string* out) const { return logcheck_.run(args, out, 30); }
  int compare(const std::string& output, std::string* out) const {
    return run({"compare", output, path("expected.txt")}, out);
  }
  testutil::ProcessUnderTest logcheck_{"depowder-logcheck"};  // its executable and a scratch directory
};

TEST_F(LogCheck, TheSameOutputMatches) {
  std::string out;
  EXPECT_EQ(compare(path("golden.lcmlog"), &out), 0) << out;
  EXPECT_NE(out.find("matched 50 (100.0 %), without a PART_POSE 0"), std::string::npos) << out;
}

TEST_F(LogCheck, AFrameTheTrackerSkippedCountsAgainstTheCoverageOnly) {
  // The tracker skips a frame when a newer one arrives first; PROGRESS still has that frame.
  // One of 50 skipped is 98 % coverage (the default minimum): a pass, not a pose at the origin.
  writeOutput(path("one_skipped.lcmlog"), {20});
  std::string out;
  EXPECT_EQ(compare(path("one_skipped.lcmlog"), &out), 0) << out;
  EXPECT_NE(out.find("matched 49 (98.0 %), without a PART_POSE 1"), std::string::npos) << out;
  EXPECT_NE(out.find("0 frames beyond tolerance"), std::string::npos) << out;

  writeOutput(path("two_skipped.lcmlog"), {20, 30});  // 96 %: below the coverage asked for
  EXPECT_EQ(compare(path("two_skipped.lcmlog"), &out), 1) << out;
  EXPECT_NE(out.find("REGRESSION FAILED"), std::string::npos) << out;
}

TEST_F(LogCheck, AFrameSkippedWhenRecordingIsNotExpected) {
  // A golden run in which the tracker skipped a frame: that frame is not in the expected output,
  // so a replay that tracks it matches every expected frame.
  writeOutput(path("golden.lcmlog"), {20});
  std::string out;
  ASSERT_EQ(run({"record", path("golden.lcmlog"), path("expected.txt")}, &out), 0) << out;
  EXPECT_NE(out.find("wrote 49 part-frames"), std::string::npos) << out;
  writeOutput(path("all.lcmlog"));
  EXPECT_EQ(compare(path("all.lcmlog"), &out), 0) << out;
  EXPECT_NE(out.find("expected 49 part-frames, replayed 50, matched 49 (100.0 %)"), std::string::npos) << out;
}

// A corrupt message is counted and skipped; the frames around it are still compared (its string
// length of 0 used to throw from the decoder and stop the check).
TEST_F(LogCheck, ACorruptMessageIsSkipped) {
  writeOutput(path("corrupt.lcmlog"), {}, -1, 20);
  std::string out;
  EXPECT_EQ(compare(path("corrupt.lcmlog"), &out), 0) << out;
  EXPECT_NE(out.find("1 undecodable or invalid messages"), std::string::npos) << out;
  EXPECT_NE(out.find("matched 50 (100.0 %)"), std::string::npos) << out;
}

// A replay without PROGRESS (the progress estimator died, or stamped its own time) fails: a
// missing eta once counted as no difference, and the replay passed.
TEST_F(LogCheck, AReplayWithoutProgressFails) {
  writeOutput(path("no_progress.lcmlog"), {}, -1, -1, false);
  std::string out;
  EXPECT_EQ(compare(path("no_progress.lcmlog"), &out), 1) << out;
  EXPECT_NE(out.find(", no PROGRESS"), std::string::npos) << out;
  EXPECT_NE(out.find("50 frames beyond tolerance"), std::string::npos) << out;
}

TEST_F(LogCheck, APoseBeyondTheToleranceFails) {
  writeOutput(path("off.lcmlog"), {}, 25);  // 5 mm off in one frame; the tolerance is 2 mm
  std::string out;
  EXPECT_EQ(compare(path("off.lcmlog"), &out), 1) << out;
  EXPECT_NE(out.find("5.00 mm"), std::string::npos) << out;
  EXPECT_NE(out.find("1 frames beyond tolerance"), std::string::npos) << out;
}

}  // namespace
