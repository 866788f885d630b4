// depowder-tracker as a process, over udpm: run by ctest inside a private network namespace
// (test/netns-run), so its multicast never leaves the namespace. POINTS in, PART_POSE out with
// the frame's utime; garbage and empty frames are reported and the process keeps running;
// SIGTERM stops it cleanly; a broken mesh is a start-up error naming the file.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include "depowder/heartbeat_t.hpp"
#include "depowder/mesh.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/process_under_test.hpp"
#include "scene.hpp"

namespace {

using namespace depowder;

const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
const std::string kCube = std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/cube.stl";

std::string cellYaml(const std::string& mesh, const Pose& init) {
  std::ostringstream s;
  s.precision(10);
  s << "cameras:\n"
       "  - {name: LEFT, position: [0.0, -0.35, 0.75], look_at: [0.0, 0.0, 0.05]}\n"
       "  - {name: RIGHT, position: [0.0, 0.35, 0.75], look_at: [0.0, 0.0, 0.05]}\n"
       "parts:\n  - {name: cube, mesh: "
    << mesh << ", xi: 0.01, initial_pose: {xyz: [" << init.translation().x() << ", " << init.translation().y() << ", "
    << init.translation().z() << "], rpy_deg: [0, 0, 0]}}\n"
    << "tracker: {heartbeat_period: 0.2}\n";
  return s.str();
}

class TrackerProcess : public ::testing::Test {
 protected:
  void start(const std::string& cell) {
    process_.start({"--config", process_.write("cell.yaml", cell), "--url", kUrl, "--prefix", process_.prefix()});
  }
  testutil::ProcessUnderTest process_{"depowder-tracker"};
};

TEST_F(TrackerProcess, PublishesPerFrameKeepsRunningOnBadInputStopsCleanly) {
  const Mesh cube = loadMesh(kCube);
  const Pose truth = tracker::scene::restingPose(cube, 0.0, 0.0, 0, 0, 0);
  Pose init = truth;
  init.translation().y() += 0.002;  // along y: the cameras see the cube's y faces, not its x faces
  start(cellYaml(kCube, init));

  node::Bus bus(kUrl, process_.prefix());
  std::vector<part_pose_t> got;
  heartbeat_t last_heartbeat;
  int heartbeats = 0;
  bus.subscribe<part_pose_t>("PART_POSE", [&](const part_pose_t& m, const std::string&) { got.push_back(m); });
  bus.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& h, const std::string&) {
    if (h.process == "depowder-tracker") last_heartbeat = h, ++heartbeats;
  });
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats > 0; }, 10)) << "no heartbeat from depowder-tracker";

  std::mt19937 rng(3);
  auto frame = [&] { return tracker::scene::render({{&cube, truth}}, 0.025, {}, rng); };
  auto waitFor = [&](std::int64_t utime) {
    return bus.spinUntil([&] { return !got.empty() && got.back().utime == utime; }, 5);
  };

  // 1. A frame: one PART_POSE with its utime, tracked near the truth.
  bus.publish("POINTS", node::encodeCloud(frame(), 1000));
  ASSERT_TRUE(waitFor(1000));
  EXPECT_EQ(got.back().part, "cube");
  EXPECT_EQ(got.back().method, "cu");
  EXPECT_EQ(got.back().status, +part_pose_t::TRACKING) << got.back().status_reason;
  EXPECT_GT(got.back().template_size, 50);
  EXPECT_LT(translationDistance(*node::fromMsg(got.back().T_cell_part), truth), 0.001);

  // 2. Garbage bytes on POINTS: a decode error, nothing published. An empty cloud: the last
  // good pose with the reason.
  bus.publishRaw("POINTS", "not a cloud", 11);
  bus.publish("POINTS", node::encodeCloud({}, 2000));
  ASSERT_TRUE(waitFor(2000));
  EXPECT_EQ(got.back().status, +part_pose_t::LOST);
  EXPECT_NE(got.back().status_reason.find("empty scan"), std::string::npos) << got.back().status_reason;

  // 3. Still running: the next frame is tracked.
  bus.publish("POINTS", node::encodeCloud(frame(), 3000));
  ASSERT_TRUE(waitFor(3000));
  EXPECT_EQ(got.back().status, +part_pose_t::TRACKING) << got.back().status_reason;
  for (const part_pose_t& m : got) EXPECT_NE(m.utime, 0);

  // 4. A frame refused (not newer), then one tracked at once: the heartbeat still says why the
  // first was refused (for 2 s), not only until the next frame.
  bus.publish("POINTS", node::encodeCloud(frame(), 2500));
  bus.publish("POINTS", node::encodeCloud(frame(), 4000));
  ASSERT_TRUE(waitFor(4000));
  const int refused_at = heartbeats;
  bool said = false;
  bus.spinUntil(
      [&] {
        said = said || (last_heartbeat.state == heartbeat_t::DEGRADED &&
                        last_heartbeat.state_reason.find("utime 2500, not newer") != std::string::npos);
        return heartbeats >= refused_at + 3;
      },
      5);
  EXPECT_TRUE(said) << last_heartbeat.state_reason;

  const int before = heartbeats;
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats >= before + 2; }, 5));
  EXPECT_GE(last_heartbeat.decode_errors, 1);
  EXPECT_GT(node::heartbeatStat(last_heartbeat, "frame_ms_p50"), 0);

  // 5. SIGTERM: a clean exit.
  EXPECT_EQ(process_.terminate(), 0);
}

// A mesh that cannot be loaded is a configuration error: exit code 1, the file named.
TEST_F(TrackerProcess, BrokenMeshIsAStartUpError) {
  const std::string broken = process_.dir() + "/broken.stl";
  std::ofstream(broken) << "solid broken\nendsolid broken\n";
  const std::string cell = process_.dir() + "/cell.yaml";
  std::ofstream(cell) << cellYaml(broken, Pose::Identity());
  const std::string log = process_.dir() + "/stderr.txt";
  EXPECT_EQ(testutil::shellExitStatus(process_.exe() + " --config " + cell + " --url memq:// 2> " + log), 1);
  std::stringstream err;
  err << std::ifstream(log).rdbuf();
  EXPECT_NE(err.str().find(broken), std::string::npos) << err.str();

  EXPECT_EQ(testutil::shellExitStatus(process_.exe() + " --help > /dev/null"), 0);
  EXPECT_EQ(testutil::shellExitStatus(process_.exe() + " --method gicp 2> /dev/null"), 2);
}

}  // namespace
