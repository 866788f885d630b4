// depowder-planner as a process, over udpm: run by ctest inside a private network namespace
// (test/netns-run). Poses and progress in, a NOZZLE_PLAN out with the frame's utime and IK
// solutions; bad messages are counted and change nothing; SIGTERM ends it cleanly.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>

#include "cube_messages.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/robot_state_t.hpp"

namespace depowder::planner {
namespace {

const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

class PlannerProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    process_.start({"--cell", process_.write("cell.yaml", test::cubeCellYaml("planner: {heartbeat_period: 0.2}\n")),
                    "--url", kUrl, "--prefix", process_.prefix()});
  }
  testutil::ProcessUnderTest process_{"depowder-planner"};
};

TEST_F(PlannerProcess, PlansFromMessagesCountsBadInputStopsCleanly) {
  node::Bus bus(kUrl, process_.prefix());
  std::vector<nozzle_plan_t> plans;
  heartbeat_t last{};
  int heartbeats = 0;
  bus.subscribe<nozzle_plan_t>("NOZZLE_PLAN", [&](const nozzle_plan_t& m, const std::string&) { plans.push_back(m); });
  bus.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& h, const std::string&) {
    if (h.process == "depowder-planner") last = h, ++heartbeats;
  });
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats > 0; }, 10)) << "no heartbeat from depowder-planner";

  // 1. Bad input first: a NaN pose and garbage on PROGRESS. Counted; no plan with waypoints.
  part_pose_t bad = test::cubePose(1000, Pose::Identity());
  bad.T_cell_part.position[2] = std::nan("");
  bus.publish("PART_POSE", bad);
  bus.publishRaw("PROGRESS", "not progress", 12);

  // 2. A pose and its progress: a plan stamped with that frame, waypoints with IK solutions.
  const Pose T = makePoseRpy({0.01, 0.0, 0.03}, 0, 0, 0.2);
  bus.publish("PART_POSE", test::cubePose(2000, T));
  bus.publish("PROGRESS", test::cubeProgress(2000, T, 0.04));
  ASSERT_TRUE(bus.spinUntil([&] { return !plans.empty() && plans.back().num_waypoints > 0; }, 10));
  const nozzle_plan_t& plan = plans.back();
  EXPECT_EQ(plan.utime, 2000);
  EXPECT_EQ(plan.part, "cube");
  EXPECT_EQ(plan.phase, +progress_t::PHASE_VACUUM_TRACKED);
  EXPECT_GT(plan.num_waypoints, 20);
  int vacuum = 0;
  for (const waypoint_t& w : plan.waypoints) vacuum += w.tool == waypoint_t::TOOL_VACUUM;
  EXPECT_GT(vacuum, 20);
  for (std::size_t i = 0; i + 1 < plans.size(); ++i) EXPECT_EQ(plans[i].num_waypoints, 0) << "only holds before";

  const int before = heartbeats;
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats >= before + 2; }, 5));
  EXPECT_GE(last.decode_errors, 1);
  EXPECT_GE(last.dropped, 1);
  EXPECT_EQ(last.state, +heartbeat_t::RUNNING) << last.state_reason;

  // 3. SIGTERM: a clean exit.
  EXPECT_EQ(process_.terminate(), 0);
}

// The clock rule over the bus: a lone pose stamped a minute behind is refused and counted, and
// nothing starts over; a log played again (its frame's PART_POSE refused, its PROGRESS taken)
// starts the planning over, counted in the heartbeat, and plans come from the new clock.
TEST_F(PlannerProcess, ALoneInputFarBehindIsRefusedTwoInARowStartOver) {
  node::Bus bus(kUrl, process_.prefix());
  nozzle_plan_t plan{};
  heartbeat_t last{};
  int heartbeats = 0;
  bus.subscribe<nozzle_plan_t>("NOZZLE_PLAN", [&](const nozzle_plan_t& m, const std::string&) { plan = m; });
  bus.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& h, const std::string&) {
    if (h.process == "depowder-planner") last = h, ++heartbeats;
  });
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats > 0; }, 10)) << "no heartbeat from depowder-planner";
  const Pose T = makePoseRpy({0.01, 0.0, 0.03}, 0, 0, 0.2);
  const auto frame = [&](std::int64_t utime) {
    bus.publish("PART_POSE", test::cubePose(utime, T));
    bus.publish("PROGRESS", test::cubeProgress(utime, T, 0.04));
  };
  const auto nextHeartbeats = [&] {
    const int before = heartbeats;
    return bus.spinUntil([&] { return heartbeats >= before + 2; }, 5);
  };
  frame(60'000'000);
  ASSERT_TRUE(bus.spinUntil([&] { return plan.utime == 60'000'000 && plan.num_waypoints > 0; }, 10));

  bus.publish("PART_POSE", test::cubePose(1'000'000, T));
  frame(60'033'000);
  ASSERT_TRUE(nextHeartbeats());
  EXPECT_EQ(last.dropped, 1);
  EXPECT_EQ(node::heartbeatStat(last, "clock_restarts"), 0);

  frame(1'033'000);  // the log from its start
  frame(1'066'000);
  ASSERT_TRUE(bus.spinUntil([&] { return plan.utime <= 1'066'000 && plan.num_waypoints > 0; }, 10))
      << "the last plan is from utime " << plan.utime << ": " << plan.reason;
  ASSERT_TRUE(nextHeartbeats());
  EXPECT_EQ(last.dropped, 2);
  EXPECT_EQ(node::heartbeatStat(last, "clock_restarts"), 1);
  EXPECT_EQ(last.state, +heartbeat_t::RUNNING) << last.state_reason;
  EXPECT_EQ(process_.terminate(), 0);
}

// A driver refuses plans until it has heard the planner's heartbeat. One that starts after the
// planner hears it at once: the planner answers the first ROBOT_STATE after a silence with a
// heartbeat, long before its next tick (10 s here), and not every ROBOT_STATE.
TEST(PlannerProcessAnnounce, FirstRobotStateAfterASilenceGetsAHeartbeat) {
  testutil::ProcessUnderTest process{"depowder-planner"};
  process.start({"--cell", process.write("cell.yaml", test::cubeCellYaml("planner: {heartbeat_period: 10}\n")), "--url",
                 kUrl, "--prefix", process.prefix()});
  node::Bus bus(kUrl, process.prefix());
  int heartbeats = 0;
  bus.subscribe<heartbeat_t>(
      "HEARTBEAT", [&](const heartbeat_t& h, const std::string&) { heartbeats += h.process == "depowder-planner"; });
  ASSERT_TRUE(bus.spinUntil([&] { return heartbeats > 0; }, 10)) << "no heartbeat from depowder-planner";
  const int started = heartbeats;
  robot_state_t robot{};
  robot.utime = 1000;
  robot.mode = robot_state_t::MODE_IDLE;
  bus.publish("ROBOT_STATE", robot);
  EXPECT_TRUE(bus.spinUntil([&] { return heartbeats > started; }, 2)) << "no heartbeat after the first ROBOT_STATE";
  const int announced = heartbeats;
  for (int k = 1; k <= 20; ++k) {  // the driver's 125 Hz: no heartbeat each
    robot.utime += 8000;
    bus.publish("ROBOT_STATE", robot);
    bus.spinUntil([] { return false; }, 0.008);
  }
  bus.spinUntil([] { return false; }, 0.3);
  EXPECT_EQ(heartbeats, announced);
  EXPECT_EQ(process.terminate(), 0);
}

}  // namespace
}  // namespace depowder::planner
