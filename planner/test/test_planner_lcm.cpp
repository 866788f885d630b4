// depowder-planner as a process, over udpm: run by ctest inside a private network namespace
// (test/netns-run). Poses and progress in, a NOZZLE_PLAN out with the frame's utime and IK
// solutions; bad messages are counted and change nothing; SIGTERM ends it cleanly.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <memory>

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

// The planner on the cube cell, its plans and heartbeats heard from its first heartbeat on.
class PlannerProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    process_.start({"--cell", process_.write("cell.yaml", test::cubeCellYaml("planner: {heartbeat_period: 0.2}\n")),
                    "--url", kUrl, "--prefix", process_.prefix()},
                   env_);
    bus_ = std::make_unique<node::Bus>(kUrl, process_.prefix());
    bus_->subscribe<nozzle_plan_t>("NOZZLE_PLAN",
                                   [&](const nozzle_plan_t& m, const std::string&) { plans_.push_back(m); });
    bus_->subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& h, const std::string&) {
      if (h.process == "depowder-planner") last_ = h, ++heartbeats_;
    });
    ASSERT_TRUE(bus_->spinUntil([&] { return heartbeats_ > 0; }, 10)) << "no heartbeat from depowder-planner";
  }
  /// Waits for two more heartbeats, so that the last one counts what was sent before.
  bool twoMoreHeartbeats() {
    const int before = heartbeats_;
    return bus_->spinUntil([&] { return heartbeats_ >= before + 2; }, 5);
  }
  /// One frame's PART_POSE and PROGRESS, stamped `utime`.
  void frame(std::int64_t utime) {
    bus_->publish("PART_POSE", test::cubePose(utime, T_));
    bus_->publish("PROGRESS", test::cubeProgress(utime, T_, 0.04));
  }
  /// Waits for the newest plan to have waypoints and come from a frame stamped at most `utime`.
  bool plannedBy(std::int64_t utime) {
    return bus_->spinUntil(
        [&] { return !plans_.empty() && plans_.back().utime <= utime && plans_.back().num_waypoints > 0; }, 10);
  }
  testutil::ProcessUnderTest process_{"depowder-planner"};
  std::vector<std::string> env_;  ///< for the process, if any
  std::unique_ptr<node::Bus> bus_;
  std::vector<nozzle_plan_t> plans_;
  heartbeat_t last_{};
  int heartbeats_ = 0;
  const Pose T_ = makePoseRpy({0.01, 0.0, 0.03}, 0, 0, 0.2);
};

TEST_F(PlannerProcess, PlansFromMessagesCountsBadInputStopsCleanly) {
  // 1. Bad input first: a NaN pose and garbage on PROGRESS. Counted; no plan with waypoints.
  part_pose_t bad = test::cubePose(1000, Pose::Identity());
  bad.T_cell_part.position[2] = std::nan("");
  bus_->publish("PART_POSE", bad);
  bus_->publishRaw("PROGRESS", "not progress", 12);

  // 2. A pose and its progress: a plan stamped with that frame, waypoints with IK solutions.
  frame(2000);
  ASSERT_TRUE(plannedBy(2000));
  const nozzle_plan_t& plan = plans_.back();
  EXPECT_EQ(plan.utime, 2000);
  EXPECT_EQ(plan.part, "cube");
  EXPECT_EQ(plan.phase, +progress_t::PHASE_VACUUM_TRACKED);
  EXPECT_GT(plan.num_waypoints, 20);
  int vacuum = 0;
  for (const waypoint_t& w : plan.waypoints) vacuum += w.tool == waypoint_t::TOOL_VACUUM;
  EXPECT_GT(vacuum, 20);
  for (std::size_t i = 0; i + 1 < plans_.size(); ++i) EXPECT_EQ(plans_[i].num_waypoints, 0) << "only holds before";

  ASSERT_TRUE(twoMoreHeartbeats());
  EXPECT_GE(last_.decode_errors, 1);
  EXPECT_GE(last_.dropped, 1);
  EXPECT_EQ(last_.state, +heartbeat_t::RUNNING) << last_.state_reason;

  // 3. SIGTERM: a clean exit.
  EXPECT_EQ(process_.terminate(), 0);
}

// The clock rule over the bus: a lone pose stamped a minute behind is refused and counted, and
// nothing starts over; a log played again (its frame's PART_POSE refused, its PROGRESS taken)
// starts the planning over, counted in the heartbeat, and plans come from the new clock.
TEST_F(PlannerProcess, ALoneInputFarBehindIsRefusedTwoInARowStartOver) {
  frame(60'000'000);
  ASSERT_TRUE(plannedBy(60'000'000));
  EXPECT_EQ(plans_.back().utime, 60'000'000);

  bus_->publish("PART_POSE", test::cubePose(1'000'000, T_));
  frame(60'033'000);
  ASSERT_TRUE(twoMoreHeartbeats());
  EXPECT_EQ(last_.dropped, 1);
  EXPECT_EQ(node::heartbeatStat(last_, "clock_restarts"), 0);

  frame(1'033'000);  // the log from its start
  frame(1'066'000);
  ASSERT_TRUE(plannedBy(1'066'000)) << "the last plan is from utime " << plans_.back().utime << ": "
                                    << plans_.back().reason;
  ASSERT_TRUE(twoMoreHeartbeats());
  EXPECT_EQ(last_.dropped, 2);
  EXPECT_EQ(node::heartbeatStat(last_, "clock_restarts"), 1);
  EXPECT_EQ(last_.state, +heartbeat_t::RUNNING) << last_.state_reason;
  EXPECT_EQ(process_.terminate(), 0);
}

// A lone pose stamped a minute ahead of the frames and of the time since is refused and counted,
// and the frames after it go on with nothing started over (it used to be taken, and the next two
// inputs, far behind it, made the planning start over).
TEST_F(PlannerProcess, ALoneInputFarAheadIsRefusedAndNothingStartsOver) {
  frame(60'000'000);
  ASSERT_TRUE(plannedBy(60'000'000));
  bus_->publish("PART_POSE", test::cubePose(120'000'000, T_));
  frame(60'033'000);
  frame(60'066'000);
  ASSERT_TRUE(twoMoreHeartbeats());
  EXPECT_EQ(last_.dropped, 1);
  EXPECT_EQ(node::heartbeatStat(last_, "clock_restarts"), 0);
  for (const nozzle_plan_t& p : plans_) EXPECT_LE(p.utime, 60'066'000) << "a plan from the future: " << p.reason;
  EXPECT_EQ(last_.state, +heartbeat_t::RUNNING) << last_.state_reason;
  EXPECT_EQ(process_.terminate(), 0);
}

// The planner's system clock, stepped through a file it reads (test/clock_step.cpp, preloaded);
// its steady clock is left alone, as NTP or an operator would.
class PlannerSteppedClock : public PlannerProcess {
 protected:
  void SetUp() override {
    step("0");
    const char* asan = std::getenv("ASAN_OPTIONS");  // its runtime wants to come first (scripts/sanitize)
    env_ = {std::string("LD_PRELOAD=") + DEPOWDER_CLOCK_STEP_LIB, "DEPOWDER_CLOCK_STEP_FILE=" + clock_,
            std::string("ASAN_OPTIONS=") + (asan ? std::string(asan) + ":" : "") + "verify_asan_link_order=0"};
    PlannerProcess::SetUp();
  }
  /// Sets the system clock's offset in seconds, e.g. "-3600" (an hour back).
  void step(const std::string& offset) { std::ofstream(clock_) << offset << "\n"; }
  const std::string clock_ = process_.dir() + "/clock";
};

// The planner's host steps its system clock an hour back. Its heartbeat goes on (it fell silent
// for the hour, timed on that clock), and a frame three seconds after the last, after three
// seconds of silence, is taken (the far-ahead rule, timing arrivals on that clock, refused it).
TEST_F(PlannerSteppedClock, AnHourBackStopsNothing) {
  frame(60'000'000);
  ASSERT_TRUE(plannedBy(60'000'000));
  ASSERT_TRUE(twoMoreHeartbeats());
  step("-3600");
  const int before = heartbeats_;
  bus_->spinUntil([] { return false; }, 3.0);
  EXPECT_GE(heartbeats_ - before, 10) << "heartbeats in the 3 s after the step (every 0.2 s)";
  frame(63'000'000);
  ASSERT_TRUE(twoMoreHeartbeats()) << "no heartbeat after the step";
  EXPECT_EQ(last_.dropped, 0) << "the frame after the silence was refused";
  EXPECT_EQ(node::heartbeatStat(last_, "clock_restarts"), 0);
  EXPECT_EQ(last_.state, +heartbeat_t::RUNNING) << last_.state_reason;
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
  robot.measured = true;
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
