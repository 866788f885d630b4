// The driver core against the b-CAP emulator over loopback TCP, as in the cell: plans are
// executed in slave mode, refused or clipped when unsafe, stopped when stale or when the
// planner's heartbeat is lost, halted at once by ESTOP, and resumed without a jump after a
// lost connection or a controller error.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "depowder/robot/driver.hpp"
#include "depowder/sim/bcap_emulator.hpp"

using namespace depowder;
using namespace depowder::robot;
using namespace std::chrono_literals;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::int64_t wallUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Nozzle pointing down, turned like the home pose (no J6 half-turn on the way in).
Pose down(double x, double y, double z) { return makePoseRpy({x, y, z}, 0, kPi, 0); }

ArmConfig cellArm() {
  ArmConfig arm;
  arm.T_cell_base = makePoseRpy({-0.55, 0.0, 0.0}, 0, 0, 0);
  arm.T_flange_nozzle = makePoseRpy({0.0, 0.0, 0.129}, 0, 0, 0);
  return arm;
}

Plan linePlan(std::int64_t id, const std::vector<Eigen::Vector3d>& pts, double speed, Tool tool = Tool::kVacuum) {
  Plan p;
  p.id = id;
  p.utime = wallUtime();
  for (const auto& x : pts) p.waypoints.push_back({down(x.x(), x.y(), x.z()), tool, speed});
  return p;
}

// Emulator + driver loop thread + a planner heartbeat thread, all in this process.
class Rig {
 public:
  explicit Rig(std::function<void(DriverConfig&)> tune = {}, int servo_lag_cycles = 0) {
    sim::BcapEmulatorConfig ecfg;
    ecfg.port = 0;
    ecfg.servo_lag_cycles = servo_lag_cycles;
    ecfg.motor_on_time_s = 0.02;
    // The late-command rule is test_bcap_emulator's and the jitter bench's. Here a host stall
    // (a virtual machine's, 14 to 96 ms) would stop the arm, and a 1 s plan go stale meanwhile.
    ecfg.late_limit_s = 0.5;
    emu_ = std::make_unique<sim::BcapEmulator>(ecfg);
    std::string err;
    if (!emu_->start(&err)) throw std::runtime_error(err);
    cfg_.arm = cellArm();
    cfg_.session.client.port = emu_->port();
    cfg_.reconnect_period_s = 0.1;
    cfg_.safety.plan_max_age_s = 30.0;  // tests about staleness set their own
    cfg_.safety.planner_heartbeat_timeout_s = 0.5;
    if (tune) tune(cfg_);
    // The driver's wall clock, which the tests can move forward to age a plan.
    driver_ = std::make_unique<Driver>(cfg_, [this] { return wallUtime() + wall_offset_us_.load(); });
    driver_->setExchangeHook([this](std::int64_t) {
      std::lock_guard<std::mutex> lock(m_);
      trace_.push_back(emu_->joints().q);
      if (estop_in_exchange_) {
        driver_->estop(true, "during an exchange");
        estop_in_exchange_ = false;  // estop() has returned
      }
    });
    driver_->plannerHeartbeat();
    loop_ = std::thread([this] { driver_->run(stop_); });
    hb_ = std::thread([this] {
      while (!stop_) {
        if (heartbeats_) {
          driver_->plannerHeartbeat();
          last_heartbeat_ = std::chrono::steady_clock::now();
        }
        std::this_thread::sleep_for(50ms);
      }
    });
  }
  ~Rig() {
    stop_ = true;
    loop_.join();
    hb_.join();
  }
  bool waitFor(const std::function<bool()>& pred, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      if (pred()) return true;
      std::this_thread::sleep_for(2ms);
    }
    return pred();
  }
  bool waitMode(DriverMode m, double seconds) {
    return waitFor([&] { return driver_->status().mode == m; }, seconds);
  }
  // Largest per-cycle joint step the emulator executed, relative to qd_max * cycle.
  double maxStepRatio() {
    std::lock_guard<std::mutex> lock(m_);
    double worst = 0;
    for (std::size_t k = 1; k < trace_.size(); ++k)
      for (int i = 0; i < 6; ++i)
        worst = std::max(worst, std::abs(trace_[k][i] - trace_[k - 1][i]) / (cfg_.arm.qd_max[i] * 0.008));
    return worst;
  }
  double maxNozzleStep() {
    std::lock_guard<std::mutex> lock(m_);
    double worst = 0;
    for (std::size_t k = 1; k < trace_.size(); ++k)
      worst = std::max(worst,
                       translationDistance(forwardNozzle(cfg_.arm, trace_[k]), forwardNozzle(cfg_.arm, trace_[k - 1])));
    return worst;
  }

  sim::BcapEmulator& emu() { return *emu_; }
  Driver& driver() { return *driver_; }
  const DriverConfig& cfg() const { return cfg_; }
  std::atomic<bool> heartbeats_{true};
  std::atomic<std::chrono::steady_clock::time_point> last_heartbeat_{};
  std::atomic<std::int64_t> wall_offset_us_{0};
  std::atomic<bool> estop_in_exchange_{false};  ///< ESTOP from the next exchange's end
  bool atNozzle(const Eigen::Vector3d& p, double tol = 1e-9) {
    return (forwardNozzle(cfg_.arm, emu_->joints().q).translation() - p).norm() < tol;
  }

 private:
  DriverConfig cfg_;
  std::unique_ptr<sim::BcapEmulator> emu_;
  std::unique_ptr<Driver> driver_;
  std::atomic<bool> stop_{false};
  std::thread loop_, hb_;
  std::mutex m_;
  std::vector<Joints> trace_;
};

Eigen::Vector3d emuNozzle(Rig& rig) { return forwardNozzle(rig.cfg().arm, rig.emu().joints().q).translation(); }

}  // namespace

TEST(DriverEmulator, FollowsAPlanToItsEnd) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0)) << rig.driver().status().reason;
  EXPECT_TRUE(rig.emu().joints().slave_mode);
  // The slvMove formats were set, not taken from whatever the controller last had: the command is
  // the joints alone (0), the reply the joints alone (2).
  EXPECT_EQ(rig.emu().stats().send_format, 0);
  EXPECT_EQ(rig.emu().stats().recv_format, 2);
  // The arm taken before its motor is switched on, as DENSO's samples do (it was the other way).
  EXPECT_EQ(rig.emu().stats().motor_on_untaken, 0);
  const auto res = rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.1, -0.05, 0.15}}, 0.2));
  ASSERT_TRUE(res.accepted) << res.reason;
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  ASSERT_TRUE(rig.waitFor([&] { return rig.emu().tool().vacuum; }, 1.0));
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 5.0)) << rig.driver().status().reason;
  // The emulated arm is at the goal (1e-9 m: the last command is the goal's IK solution).
  EXPECT_LT((emuNozzle(rig) - Eigen::Vector3d(0.1, -0.05, 0.15)).norm(), 1e-9);
  const DriverStatus st = rig.driver().status();
  EXPECT_EQ(st.plan_id, 1);
  EXPECT_EQ(st.waypoint_index, 2);
  EXPECT_LT((st.T_cell_nozzle.translation() - Eigen::Vector3d(0.1, -0.05, 0.15)).norm(), 1e-9);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_EQ(rig.emu().stats().limit_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
  EXPECT_LE(rig.maxNozzleStep(), 0.2 * 0.008 * 1.01);
}

TEST(DriverEmulator, RefusesOrClipsUnsafePlans) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  const Joints q0 = rig.emu().joints().q;
  // Outside the workspace box: refused, nothing moves.
  auto res = rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.2}, {0.35, 0.0, 0.1}}, 0.05));
  EXPECT_FALSE(res.accepted);
  EXPECT_EQ(res.status, PlanStatus::OutsideWorkspace);
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(rig.emu().joints().q, q0);
  EXPECT_EQ(rig.driver().status().mode, DriverMode::Idle);
  // Stale on arrival: refused.
  Plan old = linePlan(2, {{0.0, 0.0, 0.2}}, 0.05);
  old.utime -= 60'000'000;  // older than plan_max_age_s
  res = rig.driver().submitPlan(old);
  EXPECT_FALSE(res.accepted);
  EXPECT_NE(res.reason.find("old"), std::string::npos) << res.reason;
  // Too fast (3 m/s): clipped to max_nozzle_speed, and the arm never goes faster.
  res = rig.driver().submitPlan(linePlan(3, {{0.05, 0.0, 0.35}, {-0.15, -0.05, 0.3}}, 3.0));
  ASSERT_TRUE(res.accepted);
  EXPECT_EQ(res.status, PlanStatus::Clipped);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 10.0)) << rig.driver().status().reason;
  const double vmax = rig.cfg().trajectory.max_nozzle_speed;
  EXPECT_LE(rig.maxNozzleStep(), vmax * 0.008 * 1.01);
  EXPECT_GT(rig.maxNozzleStep(), vmax * 0.008 * 0.5);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  const auto st = rig.driver().status().stats;
  EXPECT_EQ(st.plans_refused, 2);
  EXPECT_EQ(st.plans_clipped, 1);
}

TEST(DriverEmulator, StalePlanBringsAControlledStop) {
  Rig rig([](DriverConfig& c) { c.safety.plan_max_age_s = 1.0; });
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.05)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(rig.driver().status().mode, DriverMode::Following);  // 0.3 s old: fine
  // The plan is now 1.3 s old for the driver.
  rig.wall_offset_us_ = 1'000'000;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(rig.waitMode(DriverMode::Holding, 1.0)) << rig.driver().status().reason;
  const double t_stop = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LE(t_stop, 1.0);  // one cycle to notice, then braking (loose: timing figures are the benchmark's)
  EXPECT_NE(rig.driver().status().reason.find("old"), std::string::npos) << rig.driver().status().reason;
  // HOLDING means at rest: the emulated arm no longer moves, the tool is off.
  const Joints q1 = rig.emu().joints().q;
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(rig.emu().joints().q, q1);
  EXPECT_FALSE(rig.emu().tool().vacuum);
  EXPECT_FALSE(rig.atNozzle({0.15, 0.1, 0.1}, 0.05));
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
  // A fresh plan moves on from there.
  Plan old = linePlan(2, {{0.0, 0.0, 0.25}}, 0.2);
  old.utime -= 1000;  // 1.001 s old for the driver (made within the microsecond it is checked, 1 s is the limit)
  EXPECT_FALSE(rig.driver().submitPlan(old).accepted);
  Plan fresh = linePlan(3, {{0.0, 0.0, 0.25}}, 0.2);
  fresh.utime += rig.wall_offset_us_;
  ASSERT_TRUE(rig.driver().submitPlan(fresh).accepted);
  ASSERT_TRUE(rig.waitFor(
      [&] {
        return rig.atNozzle({0.0, 0.0, 0.25});
      },
      8.0))
      << toString(rig.driver().status().mode) << ": " << rig.driver().status().reason << " | "
      << rig.driver().status().last_plan_result << " | " << rig.driver().status().plan_id;
  EXPECT_TRUE(rig.waitMode(DriverMode::Idle, 1.0));
}

// Plan ages are measured across hosts: the camera frame's utime (the host that stamped it)
// against this host's clock. A plan from the future means the clocks disagree, and an age
// measured across them would let a stale plan run on for as long as they differ: refused, and
// said so. Within plan_max_lead (clocks a little apart) it runs.
TEST(DriverEmulator, RefusesAPlanFromAheadOfItsClock) {
  Rig rig([](DriverConfig& c) {
    c.safety.plan_max_age_s = 1.5;
    c.safety.plan_max_lead_s = 0.25;
  });
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  const Joints q0 = rig.emu().joints().q;
  for (std::int64_t lead_us : {2'000'000LL, 3'600'000'000LL, 4'000'000'000'000'000LL}) {  // 2 s, 1 h, garbage
    Plan ahead = linePlan(1, {{0.0, 0.0, 0.25}}, 0.2);
    ahead.utime += lead_us;
    const PlanResult r = rig.driver().submitPlan(ahead);
    EXPECT_FALSE(r.accepted) << lead_us;
    EXPECT_NE(r.reason.find("ahead of this host's clock"), std::string::npos) << r.reason;
    EXPECT_NE(r.reason.find("synchronise"), std::string::npos) << r.reason;
  }
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(rig.emu().joints().q, q0);
  EXPECT_EQ(rig.driver().status().mode, DriverMode::Idle);
  EXPECT_EQ(rig.driver().status().stats.plans_refused, 3);
  // Behind by more than plan_max_age: refused as stale on arrival, naming a late clock as a cause.
  Plan behind = linePlan(2, {{0.0, 0.0, 0.25}}, 0.2);
  behind.utime -= 2'000'000;
  const PlanResult late = rig.driver().submitPlan(behind);
  EXPECT_FALSE(late.accepted);
  EXPECT_NE(late.reason.find("old"), std::string::npos) << late.reason;
  EXPECT_NE(late.reason.find("runs behind"), std::string::npos) << late.reason;
  // 0.2 s ahead: within the limit, it runs.
  Plan near = linePlan(3, {{0.0, 0.0, 0.25}}, 0.2);
  near.utime += 200'000;
  const PlanResult ok = rig.driver().submitPlan(near);
  ASSERT_TRUE(ok.accepted) << ok.reason;
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle({0.0, 0.0, 0.25}); }, 8.0));
}

// A planner that plans for another arm (its host's cell file differs: armModelId) is no planner
// for this driver: its plans are refused, and a running plan is brought to a controlled stop at
// once, both saying why. Its own planner's heartbeat puts things right.
TEST(DriverEmulator, APlannerOfAnotherArmIsRefused) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.05)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  rig.heartbeats_ = false;
  std::this_thread::sleep_for(60ms);  // the heartbeat thread's last one has come
  const std::string why = "depowder-planner on compute plans for another arm or workspace";
  rig.driver().plannerHeartbeat(why);
  // At once: the heartbeat timeout (0.5 s) would stop it 0.39 s from here at the earliest.
  ASSERT_TRUE(rig.waitMode(DriverMode::Holding, 0.2)) << rig.driver().status().reason;
  EXPECT_NE(rig.driver().status().reason.find(why), std::string::npos) << rig.driver().status().reason;
  EXPECT_FALSE(rig.atNozzle({0.15, 0.1, 0.1}, 0.05));
  EXPECT_LE(rig.maxStepRatio(), 1.0);
  const PlanResult r = rig.driver().submitPlan(linePlan(2, {{0.0, 0.0, 0.25}}, 0.2));
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.reason, why);
  rig.driver().plannerHeartbeat();  // its own planner again
  rig.heartbeats_ = true;
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(3, {{0.0, 0.0, 0.25}}, 0.2)).accepted);
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle({0.0, 0.0, 0.25}); }, 8.0));
}

// The planner's hold (no waypoints; before its first frame it has no source time) is a
// controlled stop: taken whatever its age, where a plan with waypoints would be refused.
TEST(DriverEmulator, AnEmptyPlanStopsWhateverItsAge) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.05)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  ASSERT_TRUE(rig.waitFor([&] { return rig.emu().tool().vacuum; }, 1.0));
  Plan hold;
  hold.id = 2;
  hold.utime = 0;
  const PlanResult r = rig.driver().submitPlan(hold);
  EXPECT_TRUE(r.accepted) << r.reason;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 2.0)) << rig.driver().status().reason;
  // At rest short of the goal, the tool off, nothing refused.
  const Joints q1 = rig.emu().joints().q;
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(rig.emu().joints().q, q1);
  EXPECT_FALSE(rig.emu().tool().vacuum);
  EXPECT_FALSE(rig.atNozzle({0.15, 0.1, 0.1}, 0.05));
  EXPECT_EQ(rig.driver().status().stats.plans_refused, 0);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  // The same plan with a waypoint is refused: it has no source time.
  Plan stale = linePlan(3, {{0.0, 0.0, 0.25}}, 0.2);
  stale.utime = 0;
  EXPECT_FALSE(rig.driver().submitPlan(stale).accepted);
  EXPECT_EQ(rig.driver().status().stats.plans_refused, 1);
}

TEST(DriverEmulator, LostPlannerHeartbeatStops) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.05)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  rig.heartbeats_ = false;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(rig.waitMode(DriverMode::Holding, 2.0));
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // At rest (HOLDING) around the 0.5 s limit (the stop starts early by the braking time; the
  // last heartbeat came up to 50 ms before t0). Loose bounds: the precise figure is
  // depowder-driver-bench-safety's.
  EXPECT_LE(t, 0.5 + 0.2);
  EXPECT_GE(t, 0.5 - 0.05 - 0.2);
  EXPECT_NE(rig.driver().status().reason.find("heartbeat"), std::string::npos);
  // Once the heartbeat is older than the limit, new plans are refused.
  std::this_thread::sleep_for(100ms);
  EXPECT_FALSE(rig.driver().submitPlan(linePlan(2, {{0.0, 0.0, 0.2}}, 0.05)).accepted);
}

// A servo that reaches each command 5 cycles (40 ms) late, as a real arm's may: the driver
// measures the lag from the replies and starts its stop that much earlier, so the arm itself (not
// just the commands) is at rest by the heartbeat's limit.
TEST(DriverEmulator, ALaggingServoIsAtRestByTheLimit) {
  for (const int lag : {0, 5}) {
    Rig rig({}, lag);
    ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
    ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.05)).accepted);
    ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
    std::this_thread::sleep_for(300ms);
    const double measured = rig.driver().status().follow_lag_s, cycle = rig.cfg().trajectory.cycle_s;
    std::printf("  servo %d cycles late: follow lag measured %.1f ms\n", lag, measured * 1000);
    // At least the lag (the driver must not stop too late), at most a cycle more.
    EXPECT_GE(measured, lag * cycle - 1e-4);
    EXPECT_LE(measured, lag * cycle + cycle);
    rig.heartbeats_ = false;
    std::this_thread::sleep_for(60ms);  // the heartbeat thread's last beat is in
    const auto last = rig.last_heartbeat_.load();
    // At rest: the emulator's arm has not moved for two cycles.
    ASSERT_TRUE(rig.waitFor([&] { return rig.emu().joints().qd == Joints{}; }, 2.0));
    const double rest = std::chrono::duration<double>(std::chrono::steady_clock::now() - last).count();
    std::printf("  last heartbeat -> arm at rest %.1f ms (limit %.0f ms)\n", rest * 1000,
                rig.cfg().safety.planner_heartbeat_timeout_s * 1000);
    // By the limit, give or take this test's 2 ms polling and a cycle of the loop's timing.
    EXPECT_LE(rest, rig.cfg().safety.planner_heartbeat_timeout_s + 0.010);
  }
}

TEST(DriverEmulator, EstopHaltsAtOnceAndNeedsAReset) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.1)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  std::this_thread::sleep_for(100ms);
  rig.driver().estop(true, "test");
  // Robot_Halt went out on the watch connection before estop() returned.
  EXPECT_TRUE(rig.emu().halted());
  const Joints q_halt = rig.emu().joints().q;
  ASSERT_TRUE(rig.waitFor([&] { return !rig.emu().joints().motor_on; }, 0.5));
  EXPECT_EQ(rig.driver().status().mode, DriverMode::EStopped);
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(rig.emu().joints().q, q_halt);
  EXPECT_FALSE(rig.emu().tool().vacuum);
  EXPECT_FALSE(rig.driver().submitPlan(linePlan(2, {{0.0, 0.0, 0.2}}, 0.05)).accepted);
  // Still stopped without a reset.
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(rig.driver().status().mode, DriverMode::EStopped);
  // Reset: re-enabled where it is, no plan, no jump.
  rig.driver().estop(false, "reset");
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 2.0)) << rig.driver().status().reason;
  EXPECT_TRUE(rig.emu().joints().motor_on);
  EXPECT_EQ(rig.emu().joints().q, q_halt);
  EXPECT_EQ(rig.driver().status().plan_id, -1);
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(3, {{0.0, 0.0, 0.2}}, 0.2)).accepted);
  ASSERT_TRUE(rig.waitFor([&] { return (emuNozzle(rig) - Eigen::Vector3d(0, 0, 0.2)).norm() < 1e-9; }, 5.0));
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
}

// An ESTOP that comes while the loop is between its exchange and its status (a button pressed at
// any moment) is reported at once and stays reported: the status never goes back to FOLLOWING.
TEST(DriverEmulator, AnEstopDuringAnExchangeIsReportedAtOnce) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.15, 0.1, 0.1}}, 0.1)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  rig.estop_in_exchange_ = true;
  // Watched without a pause from the ESTOP until the loop has switched the motor off, and some
  // cycles more: before the fix, the status said FOLLOWING from that exchange's end until then.
  int other = 0;
  const auto end = std::chrono::steady_clock::now() + 200ms;
  while (std::chrono::steady_clock::now() < end)
    if (!rig.estop_in_exchange_ && rig.driver().status().mode != DriverMode::EStopped) ++other;
  ASSERT_FALSE(rig.estop_in_exchange_) << "no exchange in 200 ms";
  EXPECT_EQ(other, 0) << "polls that saw a mode other than ESTOPPED";
  EXPECT_FALSE(rig.emu().joints().motor_on);
  EXPECT_EQ(rig.driver().status().mode, DriverMode::EStopped);
}

// A reset that cannot re-enable (the arm was moved outside the configured limits while stopped)
// is tried again every reconnect_period, not on every 8 ms cycle, and succeeds once the arm is back.
TEST(DriverEmulator, AFailedResetIsRetriedEveryReconnectPeriod) {
  const Joints home = ArmConfig().q_home;
  Rig rig([&](DriverConfig& c) { c.arm.q_max[0] = home[0] + 0.05; });
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  rig.driver().estop(true, "test");
  ASSERT_TRUE(rig.waitMode(DriverMode::EStopped, 1.0));
  ASSERT_TRUE(rig.waitFor([&] { return !rig.emu().joints().motor_on; }, 1.0));
  Joints outside = home;
  outside[0] = home[0] + 0.1;
  ASSERT_TRUE(rig.emu().setJoints(outside));
  rig.driver().estop(false, "reset");
  ASSERT_TRUE(rig.waitMode(DriverMode::Fault, 2.0)) << rig.driver().status().reason;
  EXPECT_NE(rig.driver().status().reason.find("J1 at"), std::string::npos) << rig.driver().status().reason;
  const std::int64_t before = rig.emu().stats().packets;
  // Five periods of 0.1 s: about six attempts (ClearError and CurJnt, and the first one's release
  // of the arm); on every cycle, about 60.
  std::this_thread::sleep_for(500ms);
  EXPECT_LE(rig.emu().stats().packets - before, 20);
  ASSERT_TRUE(rig.emu().setJoints(home));
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 2.0)) << rig.driver().status().reason;
  EXPECT_EQ(rig.emu().joints().q, home);
}

TEST(DriverEmulator, LostConnectionResumesWithoutAJump) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(
      rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.1, 0.1, 0.2}, {-0.1, 0.1, 0.2}}, 0.25)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  std::this_thread::sleep_for(300ms);
  rig.emu().dropConnections();
  // The controller stopped the arm when its client vanished; the driver reconnects, re-reads
  // the position and resumes the plan from there.
  ASSERT_TRUE(rig.waitFor([&] { return rig.driver().status().stats.reconnects == 1; }, 2.0))
      << rig.driver().status().reason;
  EXPECT_TRUE(rig.emu().lastHaltTime().has_value());
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle({-0.1, 0.1, 0.2}); }, 15.0)) << rig.driver().status().reason;
  EXPECT_TRUE(rig.waitMode(DriverMode::Idle, 1.0));
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
}

TEST(DriverEmulator, ControllerErrorIsClearedAndResumed) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {{0.0, 0.0, 0.3}, {0.1, 0.1, 0.15}}, 0.2)).accepted);
  ASSERT_TRUE(rig.waitMode(DriverMode::Following, 1.0));
  std::this_thread::sleep_for(200ms);
  rig.emu().raiseError("test collision");
  EXPECT_TRUE(rig.emu().halted());
  ASSERT_TRUE(rig.waitFor([&] { return rig.driver().status().stats.faults == 1; }, 1.0));
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle({0.1, 0.1, 0.15}); }, 15.0)) << rig.driver().status().reason;
  EXPECT_TRUE(rig.waitMode(DriverMode::Idle, 1.0));
  EXPECT_EQ(rig.driver().status().stats.faults, 1);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
}

// An arm found outside the configured joint limits is not enabled: the driver reports which
// joint and where, moves nothing, and enables once the arm is back inside.
TEST(DriverEmulator, AnArmOutsideTheLimitsIsNotEnabled) {
  const Joints home = ArmConfig().q_home;
  Rig rig([&](DriverConfig& c) { c.arm.q_max[0] = home[0] - 0.1; });
  ASSERT_TRUE(rig.waitMode(DriverMode::Fault, 3.0)) << rig.driver().status().reason;
  EXPECT_NE(rig.driver().status().reason.find("J1 at"), std::string::npos) << rig.driver().status().reason;
  EXPECT_NE(rig.driver().status().reason.find("outside the configured limits"), std::string::npos);
  std::this_thread::sleep_for(300ms);  // three retries
  EXPECT_EQ(rig.driver().status().mode, DriverMode::Fault);
  EXPECT_EQ(rig.emu().joints().q, home);
  // A fault with the arm read: where it is, for the planner and the self-filter.
  EXPECT_TRUE(rig.driver().status().measured);
  EXPECT_EQ(rig.driver().status().q, home);
  Joints inside = home;
  inside[0] = home[0] - 0.2;
  ASSERT_TRUE(rig.emu().setJoints(inside));
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0)) << rig.driver().status().reason;
  EXPECT_EQ(rig.emu().joints().q, inside);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
}

// A controller refusing the connection (here: an I/O variable it does not have) before the driver
// has ever read the arm: FAULT, with joints all 0 that are not the arm's, and said so (the
// planner once planned from them as it did from a disconnected driver's).
TEST(DriverEmulator, AFaultBeforeTheFirstReadHasNotMeasuredTheArm) {
  Rig rig([](DriverConfig& c) { c.session.vacuum_variable = "VALVE1"; });
  ASSERT_TRUE(rig.waitMode(DriverMode::Fault, 3.0)) << rig.driver().status().reason;
  const DriverStatus st = rig.driver().status();
  EXPECT_NE(st.reason.find("VALVE1"), std::string::npos) << st.reason;
  EXPECT_FALSE(st.measured);
  EXPECT_EQ(st.q, Joints{});
  EXPECT_EQ(st.stats.exchanges, 0);
}

// A plan taken while the controller is away is prepared from the last command; if the arm was
// moved meanwhile (a jog, a simulator reset), the driver prepares it again from where the arm is
// on reconnecting: the nozzle goes straight to the first waypoint (it once went by way of the
// old position's joint-space path).
TEST(DriverEmulator, APlanTakenWhileAwayStartsFromWhereTheArmIs) {
  Rig rig([](DriverConfig& c) { c.reconnect_period_s = 1.5; });
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  EXPECT_TRUE(rig.driver().status().measured);
  rig.emu().dropConnections();
  ASSERT_TRUE(rig.waitMode(DriverMode::Disconnected, 1.0)) << rig.driver().status().reason;
  EXPECT_FALSE(rig.driver().status().measured) << "the arm may move while the driver is away";
  const Eigen::Vector3d first(0.0, 0.0, 0.25), last(0.1, 0.0, 0.25), moved(0.0, 0.12, 0.2);
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {first, last}, 0.1)).accepted);
  const auto q = inverseNozzle(rig.cfg().arm, down(moved.x(), moved.y(), moved.z()), rig.emu().joints().q);
  ASSERT_TRUE(q.has_value());
  ASSERT_TRUE(rig.emu().setJoints(*q));
  ASSERT_TRUE(rig.waitFor([&] { return rig.driver().status().stats.reconnects == 1; }, 3.0));
  std::vector<Eigen::Vector3d> path;
  ASSERT_TRUE(rig.waitFor(
      [&] {
        path.push_back(emuNozzle(rig));
        return (path.back() - first).norm() < 1e-6;
      },
      10.0))
      << rig.driver().status().reason;
  // Each point of the way lies on the segment from where the arm was put to the first waypoint.
  const Eigen::Vector3d dir = (first - moved).normalized();
  double off = 0;
  for (const Eigen::Vector3d& p : path) off = std::max(off, ((p - moved) - (p - moved).dot(dir) * dir).norm());
  EXPECT_LT(off, 0.002) << "the nozzle left the straight way to the first waypoint";
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle(last); }, 10.0)) << rig.driver().status().reason;
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
}

// A tool write the controller refuses mid-plan ends the slave session as a refused slvMove does:
// the driver re-enables from where the arm is and goes on. It once stayed in slave mode and went
// on computing commands it did not send, and its next slvMove jumped to where they had led.
TEST(DriverEmulator, ARefusedToolWriteRestartsFromWhereTheArmIs) {
  Rig rig;
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  const Eigen::Vector3d last(0.1, 0.0, 0.25);
  Plan plan = linePlan(1, {{-0.1, 0.0, 0.25}, {0.0, 0.0, 0.25}, last}, 0.2, Tool::kOff);
  plan.waypoints[2].tool = Tool::kAir;  // switched at speed, on the way to the last waypoint
  rig.emu().refuseIoWritesForTest(30);
  ASSERT_TRUE(rig.driver().submitPlan(plan).accepted);
  ASSERT_TRUE(rig.waitFor(
      [&] { return rig.driver().status().reason.find("writing the tool output IO24") != std::string::npos; }, 10.0))
      << rig.driver().status().reason;
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle(last); }, 15.0)) << rig.driver().status().reason;
  EXPECT_TRUE(rig.emu().tool().air);
  EXPECT_GE(rig.driver().status().stats.faults, 1);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
}

// An arm moved out of the workspace box while the controller was away (jogged) is led back in by
// the plan it resumes; only leaving the box stops the arm. The per-command check once compared
// each command with itself, so it never stopped an arm leaving and stopped this one at once.
TEST(DriverEmulator, AnArmOutsideTheBoxIsLedBackIn) {
  Rig rig([](DriverConfig& c) { c.reconnect_period_s = 1.0; });
  ASSERT_TRUE(rig.waitMode(DriverMode::Idle, 3.0));
  rig.emu().dropConnections();
  ASSERT_TRUE(rig.waitMode(DriverMode::Disconnected, 1.0)) << rig.driver().status().reason;
  const Eigen::Vector3d first(0.0, 0.1, 0.25), last(0.1, 0.0, 0.25), outside(0.0, 0.2, 0.25);
  ASSERT_FALSE(rig.cfg().safety.workspace.contains(outside, rig.cfg().safety.workspace_margin));
  ASSERT_TRUE(rig.driver().submitPlan(linePlan(1, {first, last}, 0.1)).accepted);
  const auto q = inverseNozzle(rig.cfg().arm, down(outside.x(), outside.y(), outside.z()), rig.emu().joints().q);
  ASSERT_TRUE(q.has_value());
  ASSERT_TRUE(rig.emu().setJoints(*q));
  ASSERT_TRUE(rig.waitFor([&] { return rig.driver().status().stats.reconnects == 1; }, 3.0));
  ASSERT_TRUE(rig.waitFor([&] { return rig.atNozzle(last); }, 10.0)) << rig.driver().status().reason;
  EXPECT_EQ(rig.driver().status().stats.safety_stops, 0);
  EXPECT_EQ(rig.emu().stats().speed_errors, 0);
  EXPECT_LE(rig.maxStepRatio(), 1.0);
}
