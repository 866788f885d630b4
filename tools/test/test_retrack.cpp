// depowder-retrack on the golden log of the static cube (logs/static_cube.lcmlog), and on a copy
// recorded and stamped an hour earlier from frame 45 on, as if the recording host's clock had
// been stepped back: the same 89 frames are tracked and counted, and stderr names the step.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "depowder/point_cloud_t.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/test_messages.hpp"

namespace {

using namespace depowder;

const std::string kGolden = std::string(DEPOWDER_SOURCE_DIR) + "/logs/static_cube.lcmlog";
const std::string kCell = std::string(DEPOWDER_SOURCE_DIR) + "/config/scenarios/static.yaml";
constexpr int kStepAt = 45;                          // the first POINTS frame after the step
constexpr std::int64_t kStep = -3600LL * 1'000'000;  // us

/// A copy of `from` whose events from POINTS frame kStepAt on are recorded kStep later, and
/// whose POINTS frames from there on are stamped so.
void writeStepped(const std::string& from, const std::string& to) {
  lcm::LogFile in(from, "r"), out(to, "w");
  ASSERT_TRUE(in.good() && out.good()) << from << ", " << to;
  int frame = 0;
  for (const lcm::LogEvent* e = in.readNextEvent(); e; e = in.readNextEvent()) {
    std::vector<std::uint8_t> data(static_cast<const std::uint8_t*>(e->data),
                                   static_cast<const std::uint8_t*>(e->data) + e->datalen);
    const bool stepped = (frame += e->channel == "POINTS") > kStepAt;
    if (e->channel == "POINTS" && stepped) {
      point_cloud_t m;
      ASSERT_GE(m.decode(data.data(), 0, static_cast<int>(data.size())), 0);
      m.utime += kStep;
      data = testutil::encoded(m);
    }
    ASSERT_EQ(testutil::writeBytes(out, e->channel, std::move(data), e->timestamp + (stepped ? kStep : 0)), 0);
  }
  ASSERT_GT(frame, kStepAt) << "the golden log has " << frame << " POINTS frames";
}

class Retrack : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::ifstream(kGolden)) GTEST_SKIP() << kGolden << " is absent";
  }
  std::string path(const std::string& file) const { return retrack_.dir() + "/" + file; }
  /// Runs depowder-retrack on `log` to its end: its exit status, and what it printed in `out`.
  int run(const std::string& log, std::string* out) const { return retrack_.run({log, "--cell", kCell}, out); }
  /// What it printed from the line "N frames tracked" on: the counts and the error percentiles.
  static std::string summary(const std::string& out) {
    const std::size_t at = out.find(" frames tracked");
    return at == std::string::npos ? "" : out.substr(out.rfind('\n', at) + 1);
  }
  testutil::ProcessUnderTest retrack_{"depowder-retrack"};  // its executable and a scratch directory
};

TEST_F(Retrack, AStepOfTheRecordingClockLosesNoFrame) {
  std::string golden, stepped;
  ASSERT_EQ(run(kGolden, &golden), 0) << golden;
  ASSERT_NE(summary(golden).find("89 frames tracked"), std::string::npos) << golden;
  EXPECT_NE(summary(golden).find("tracking 89"), std::string::npos) << golden;
  EXPECT_EQ(golden.find("clock stepped"), std::string::npos) << golden;

  writeStepped(kGolden, path("stepped.lcmlog"));
  ASSERT_EQ(run(path("stepped.lcmlog"), &stepped), 0) << stepped;
  EXPECT_EQ(summary(stepped), summary(golden)) << stepped;
  // The golden log has no heartbeat: the step back counts no time (the SIM_TRUTH before the frame
  // was recorded 0.1 ms before it).
  EXPECT_NE(stepped.find("depowder-retrack: the recording host's clock stepped -3600.000 s at 1.48 s into the log"),
            std::string::npos)
      << stepped;
}

}  // namespace
