// depowder-progress as a process, over udpm: run by ctest inside a private network namespace
// (test/netns-run), so its multicast never leaves the namespace. Frames in, PROGRESS out with
// the frame's utime; garbage and invalid poses are counted and the process keeps running.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <sstream>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/progress_t.hpp"
#include "scenes.hpp"

namespace depowder::progress {
namespace {

const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

Cloud cubeScene(double h) {
  Cloud scan =
      test::powderPlane(h, 0.15, 0.0025, [](double x, double y) { return std::abs(x) <= 0.03 && std::abs(y) <= 0.03; });
  for (const Point& p : test::boxSurface({-0.03, -0.03, 0.02}, {0.03, 0.03, 0.08}, 0.003))
    if (p.z() >= h) scan.push_back(p);
  return scan;
}

part_pose_t poseMsg(std::int64_t utime, const Pose& pose) {
  part_pose_t m;
  m.utime = utime;
  m.part = "cube";
  m.T_cell_part = node::toMsg(pose);
  m.template_size = 0;
  return m;
}

class ProgressProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ostringstream cell;
    cell << "parts:\n  - name: cube\n    mesh: " << DEPOWDER_SOURCE_DIR << "/config/parts/cube.stl\n    xi: 0.01\n"
         << "    initial_pose: {xyz: [0, 0, 0.05], rpy_deg: [0, 0, 0]}\n"
         << "progress: {pose_wait: 0.1, heartbeat_period: 0.2}\n";
    process_.start({"--cell", process_.write("cell.yaml", cell.str()), "--url", kUrl, "--prefix", process_.prefix()});
  }
  testutil::ProcessUnderTest process_{"depowder-progress"};
};

TEST_F(ProgressProcess, PublishesPerFrameKeepsRunningOnBadInputStopsCleanly) {
  node::Bus bus(kUrl, process_.prefix());
  std::vector<progress_t> got;
  heartbeat_t last_heartbeat;
  int heartbeats = 0;
  bus.subscribe<progress_t>("PROGRESS", [&](const progress_t& m, const std::string&) { got.push_back(m); });
  bus.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& h, const std::string&) {
    if (h.process == "depowder-progress") last_heartbeat = h, ++heartbeats;
  });
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats > 0; }, 10)) << "no heartbeat from depowder-progress";

  // 1. A frame and its pose: one PROGRESS with the frame's utime and Eq. 2's value.
  const Pose init = makePoseRpy({0, 0, 0.05}, 0, 0, 0);
  bus.publish("POINTS", node::encodeCloud(cubeScene(0.05), 1000));
  bus.publish("PART_POSE", poseMsg(1000, init));
  ASSERT_TRUE(bus.spinUntil([&] { return !got.empty(); }, 5));
  EXPECT_EQ(got[0].utime, 1000);
  EXPECT_EQ(got[0].part, "cube");
  EXPECT_EQ(got[0].status, +progress_t::OK) << got[0].status_reason;
  EXPECT_NEAR(got[0].eta, 0.5, 0.01);
  EXPECT_GT(got[0].num_contour, 20);

  // 2. Garbage on POINTS, a pose with a NaN quaternion: counted, nothing published for them.
  bus.publishRaw("POINTS", "not a cloud", 11);
  part_pose_t bad = poseMsg(2000, init);
  bad.T_cell_part.orientation[1] = std::numeric_limits<double>::quiet_NaN();
  bus.publish("PART_POSE", bad);

  // 3. A frame 20 s later with no pose: NO_POSE after pose_wait, naming the cause.
  bus.publish("POINTS", node::encodeCloud(cubeScene(0.05), 20'000'000));
  ASSERT_TRUE(bus.spinUntil([&] { return got.size() >= 2; }, 5));
  EXPECT_EQ(got[1].utime, 20'000'000);
  EXPECT_EQ(got[1].status, +progress_t::NO_POSE);
  EXPECT_NE(got[1].status_reason.find("pose_staleness"), std::string::npos) << got[1].status_reason;
  const int before = heartbeats;
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats >= before + 2; }, 5));
  EXPECT_GE(last_heartbeat.decode_errors, 1);
  EXPECT_EQ(last_heartbeat.state, +heartbeat_t::DEGRADED);
  EXPECT_NE(last_heartbeat.state_reason.find("cube"), std::string::npos) << last_heartbeat.state_reason;

  // 3b. A good frame again (no part problem left), then a PART_POSE for a part not in the cell:
  //     said in the heartbeats that follow (it once lasted one pass of the loop, about 10 ms, and
  //     a heartbeat seldom went out in it).
  bus.publish("POINTS", node::encodeCloud(cubeScene(0.05), 20'100'000));
  bus.publish("PART_POSE", poseMsg(20'100'000, init));
  ASSERT_TRUE(bus.spinUntil([&] { return got.size() >= 3; }, 5));
  EXPECT_EQ(got[2].status, +progress_t::OK) << got[2].status_reason;
  part_pose_t stranger = poseMsg(20'200'000, init);
  stranger.part = "bunny";
  bus.publish("PART_POSE", stranger);
  const int after = heartbeats;
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats >= after + 2; }, 5));
  EXPECT_EQ(last_heartbeat.state, +heartbeat_t::DEGRADED);
  EXPECT_NE(last_heartbeat.state_reason.find("unknown part 'bunny'"), std::string::npos) << last_heartbeat.state_reason;

  // 4. SIGTERM: a clean exit.
  EXPECT_EQ(process_.terminate(), 0);
}

}  // namespace
}  // namespace depowder::progress
