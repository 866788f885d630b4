// depowder-driver as a process over udpm (run inside test/netns-run): ROBOT_STATE rate, a plan
// executed on the emulator, a malformed plan refused, ESTOP and its reset, the planner's
// heartbeat lost, a planner of another arm and two planners at once refused, and an orderly
// shutdown on SIGTERM.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

#include "depowder/estop_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "driver_process.hpp"

namespace depowder::robot::test {
namespace {

constexpr double kPi = 3.14159265358979323846;
Pose down(double x, double y, double z) { return makePoseRpy({x, y, z}, 0, kPi, 0); }

estop_t estopMsg(bool stop) {
  estop_t e;
  e.utime = node::nowUtime();
  e.source = "test";
  e.stop = stop;
  e.reason = stop ? "button" : "cleared";
  return e;
}

TEST(DriverProcess, PlansStateEstopHeartbeatShutdown) {
  // plan_max_age: on a loaded machine a slvMove can come late (> 16 ms); the driver then clears
  // the fault and resumes the plan where the arm is, which it only does for a fresh plan. The
  // test publishes each plan once (a planner re-plans every frame), so it must stay fresh.
  DriverProcess p("  planner_heartbeat_timeout: 0.5\n  plan_max_age: 20\n");
  robot_state_t last;
  int states = 0;
  heartbeat_t hb;
  bool have_hb = false;
  p.bus->subscribe<robot_state_t>("ROBOT_STATE", [&](const robot_state_t& m, const std::string&) {
    last = m;
    ++states;
  });
  p.bus->subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& h, const std::string&) {
    if (h.process == "depowder-driver") hb = h, have_hb = true;
  });
  ASSERT_TRUE(p.spinUntil([&] { return states > 0 && last.mode == robot_state_t::MODE_IDLE; }, 10))
      << "no IDLE ROBOT_STATE: " << last.mode_reason;

  // 1. ROBOT_STATE rate over 2 s (125 Hz configured).
  const int n0 = states;
  p.spinUntil([] { return false; }, 2.0);
  const double rate = (states - n0) / 2.0;
  std::printf("ROBOT_STATE: %.1f Hz\n", rate);
  EXPECT_GE(rate, 100.0);

  // 2. A plan with the planner alive: executed to its end on the emulated arm.
  // The planner's heartbeat every 100 ms (with an arm_model figure if >= 0).
  auto last_hb = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  auto beat = [&](double arm_model) {
    if (std::chrono::steady_clock::now() - last_hb > std::chrono::milliseconds(100)) {
      p.plannerHeartbeat(arm_model);
      last_hb = std::chrono::steady_clock::now();
    }
  };
  auto alive = [&] { beat(-1); };
  // 0.3 s of the bus with `beats` called at each spin.
  auto keep = [&](const std::function<void()>& beats) {
    p.spinUntil(
        [&] {
          beats();
          return false;
        },
        0.3);
  };
  keep(alive);
  p.bus->publish("NOZZLE_PLAN", p.plan(1, {down(0, 0, 0.3), down(0.1, -0.05, 0.2)}, 0.25));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_FOLLOWING;
      },
      2))
      << last.mode_reason;
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_IDLE && last.plan_id == 1;
      },
      10))
      << last.mode_reason;
  EXPECT_LT((p.emuNozzle() - Eigen::Vector3d(0.1, -0.05, 0.2)).norm(), 1e-9);
  EXPECT_NEAR(last.T_cell_nozzle.position[0], 0.1, 1e-9);
  EXPECT_NEAR(last.T_cell_nozzle.position[2], 0.2, 1e-9);
  EXPECT_EQ(last.waypoint_index, 2);
  EXPECT_TRUE(p.emu->tool().vacuum);  // the last waypoint's tool stays on until the next plan

  // 3. A malformed plan (NaN quaternion): refused, reported in the heartbeat, nothing moves.
  auto bad = p.plan(2, {down(0, 0, 0.25)}, 0.1);
  bad.waypoints[0].T_cell_nozzle.orientation[0] = std::numeric_limits<double>::quiet_NaN();
  const auto q_before = p.emu->joints().q;
  p.bus->publish("NOZZLE_PLAN", bad);
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return have_hb && hb.state == heartbeat_t::DEGRADED;
      },
      3));
  EXPECT_NE(hb.state_reason.find("plan 2 refused"), std::string::npos) << hb.state_reason;
  EXPECT_EQ(p.emu->joints().q, q_before);

  // 4. ESTOP while moving: halted in the emulator at once, motor off, ESTOPPED until reset.
  p.bus->publish("NOZZLE_PLAN", p.plan(3, {down(-0.15, 0.1, 0.1)}, 0.1));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_FOLLOWING;
      },
      2));
  const auto t_estop = std::chrono::steady_clock::now();
  p.bus->publish("ESTOP", estopMsg(true));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return p.emu->halted();
      },
      1));
  const auto halt = p.emu->lastHaltTime();
  ASSERT_TRUE(halt.has_value());
  const double ms = std::chrono::duration<double, std::milli>(*halt - t_estop).count();
  std::printf("ESTOP publish -> arm halted in the emulator: %.2f ms\n", ms);
  EXPECT_LT(ms, 100.0);
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_ESTOPPED;
      },
      1));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return !p.emu->joints().motor_on;
      },
      1));
  EXPECT_FALSE(p.emu->tool().vacuum);
  const auto q_halt = p.emu->joints().q;
  keep(alive);
  EXPECT_EQ(p.emu->joints().q, q_halt);
  EXPECT_EQ(last.mode, +robot_state_t::MODE_ESTOPPED);
  p.bus->publish("ESTOP", estopMsg(false));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_IDLE;
      },
      3))
      << last.mode_reason;
  EXPECT_EQ(p.emu->joints().q, q_halt);  // re-enabled where it stopped
  EXPECT_TRUE(p.emu->joints().motor_on);

  // 5. The planner goes quiet during a plan: controlled stop, HOLDING.
  p.bus->publish("NOZZLE_PLAN", p.plan(4, {down(0.15, 0.1, 0.1)}, 0.05));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_FOLLOWING;
      },
      2));
  ASSERT_TRUE(p.spinUntil([&] { return last.mode == robot_state_t::MODE_HOLDING; }, 2)) << last.mode_reason;
  EXPECT_NE(last.mode_reason.find("heartbeat"), std::string::npos) << last.mode_reason;
  EXPECT_EQ(p.emu->stats().speed_errors, 0);
  std::printf("late slvMove faults recovered from: %lld\n", static_cast<long long>(p.emu->stats().late_errors));

  // 6. A planner that plans for another arm (its cell file's robot section differs): its plans
  // are refused, saying so; the heartbeat of one without the figure counts again.
  auto other_arm = [&] { beat(12345); };
  keep(other_arm);
  const auto q_hold = p.emu->joints().q;
  p.bus->publish("NOZZLE_PLAN", p.plan(5, {down(0, 0, 0.25)}, 0.1));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        other_arm();
        return have_hb && hb.state_reason.find("plan 5 refused") != std::string::npos;
      },
      3))
      << hb.state_reason;
  EXPECT_NE(hb.state_reason.find("the planner test:1 plans for another arm or workspace (arm_model 12345"),
            std::string::npos)
      << hb.state_reason;
  EXPECT_EQ(p.emu->joints().q, q_hold);
  keep(alive);
  p.bus->publish("NOZZLE_PLAN", p.plan(6, {down(0, 0, 0.25)}, 0.1));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.plan_id == 6 && last.mode == robot_state_t::MODE_IDLE;
      },
      10))
      << last.mode_reason;

  // 7. A second planner on the bus (another cell, a laptop): no plan is followed while both
  // publish; once it says it stops, the first one's plans are.
  auto two = [&] {
    const bool due = std::chrono::steady_clock::now() - last_hb > std::chrono::milliseconds(100);
    beat(-1);
    if (due) p.plannerHeartbeat(-1, 2);
  };
  keep(two);
  p.bus->publish("NOZZLE_PLAN", p.plan(7, {down(0.05, 0, 0.25)}, 0.1));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        two();
        return have_hb && hb.state_reason.find("plan 7 refused") != std::string::npos;
      },
      3))
      << hb.state_reason;
  EXPECT_NE(hb.state_reason.find("2 planners publish plans (test:1, test:2)"), std::string::npos) << hb.state_reason;
  EXPECT_NE(last.plan_id, 7);
  p.plannerHeartbeat(-1, 2, heartbeat_t::STOPPING);
  keep(alive);
  p.bus->publish("NOZZLE_PLAN", p.plan(8, {down(0.05, 0, 0.25)}, 0.1));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.plan_id == 8 && last.mode == robot_state_t::MODE_IDLE;
      },
      10))
      << last.mode_reason;

  // 8. ESTOP right behind a long plan: the driver prepares a plan (IK along all of it) on its
  // main thread, and takes ESTOP on a thread of its own: the arm halts at once, not once the plan
  // is prepared, and the plan is refused.
  std::vector<Pose> zigzag;
  for (int k = 0; k < 1500; ++k) zigzag.push_back(k % 2 ? down(-0.15, 0.1, 0.1) : down(0.15, -0.1, 0.3));
  const nozzle_plan_t long_plan = p.plan(9, zigzag, 0.1);
  const std::int64_t halts_before = p.emu->stats().halts;
  const auto t_long = std::chrono::steady_clock::now();
  p.bus->publish("NOZZLE_PLAN", long_plan);
  p.bus->publish("ESTOP", estopMsg(true));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return p.emu->stats().halts > halts_before;
      },
      5));
  const double behind_ms = std::chrono::duration<double, std::milli>(*p.emu->lastHaltTime() - t_long).count();
  std::printf("ESTOP published behind a %d-waypoint plan -> arm halted: %.2f ms\n", long_plan.num_waypoints, behind_ms);
  EXPECT_LT(behind_ms, 100.0);
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return have_hb && hb.state_reason.find("plan 9 refused: ESTOP is active") != std::string::npos;
      },
      5))
      << hb.state_reason;
  p.bus->publish("ESTOP", estopMsg(false));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_IDLE;
      },
      3))
      << last.mode_reason;
  EXPECT_NE(last.plan_id, 9);

  // 9. SIGTERM while following a plan: the arm brakes to rest before slave mode is left (leaving
  // it at speed stops a real arm at once), then the orderly shutdown (arm given back, motor
  // off), exit 0.
  const Eigen::Vector3d from = p.emuNozzle();
  p.bus->publish("NOZZLE_PLAN", p.plan(10, {down(-0.15, -0.1, 0.3)}, 0.25));
  ASSERT_TRUE(p.spinUntil(
      [&] {
        alive();
        return last.mode == robot_state_t::MODE_FOLLOWING && (p.emuNozzle() - from).norm() > 0.03;
      },
      5))
      << last.mode_reason;
  EXPECT_EQ(p.terminate(), 0);
  EXPECT_EQ(p.emu->stats().abrupt_exits, 0);
  EXPECT_GT((p.emuNozzle() - from).norm(), 0.03);
  EXPECT_FALSE(p.emu->joints().motor_on);
  EXPECT_FALSE(p.emu->joints().slave_mode);
  EXPECT_FALSE(p.emu->tool().vacuum);
}

}  // namespace
}  // namespace depowder::robot::test
