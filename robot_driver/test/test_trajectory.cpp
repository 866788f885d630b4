// Trajectory generation: plan validation (workspace, reachability, speeds), limits on every
// 8 ms sample (joint speed and acceleration by finite differences), nozzle speed, exact
// arrival, continuity across plan updates and controlled stops.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "depowder/robot/trajectory.hpp"

using namespace depowder;
using namespace depowder::robot;

namespace {

constexpr double kPi = 3.14159265358979323846;

ArmConfig cellArm() {
  ArmConfig arm;
  arm.T_cell_base = makePoseRpy({-0.55, 0.0, 0.0}, 0, 0, 0);
  arm.T_flange_nozzle = makePoseRpy({0.0, 0.0, 0.129}, 0, 0, 0);
  return arm;
}

Pose down(double x, double y, double z) { return makePoseRpy({x, y, z}, kPi, 0, 0); }

Plan linePlan(std::int64_t id, const std::vector<Eigen::Vector3d>& pts, double speed, Tool tool = Tool::kVacuum) {
  Plan p;
  p.id = id;
  for (const auto& x : pts) p.waypoints.push_back({down(x.x(), x.y(), x.z()), tool, speed});
  return p;
}

// Runs the generator and checks every sample against the joint limits; returns the samples.
struct RunResult {
  std::vector<TrajectorySample> samples;
  double max_speed_ratio = 0;  // max over joints and samples of |qd| / qd_max
  double max_acc_ratio = 0;    // max over joints and samples of |qdd| / qdd_max
  double max_nozzle_speed = 0;
};

RunResult run(TrajectoryGenerator& gen, const ArmConfig& arm, int cycles, const TrajectoryConfig& cfg,
              std::function<void(int)> hook = {}) {
  RunResult r;
  Joints prev = gen.current().q, prev2 = prev;
  Eigen::Vector3d p_prev = forwardNozzle(arm, prev).translation();
  for (int k = 0; k < cycles; ++k) {
    if (hook) hook(k);
    const TrajectorySample s = gen.step();
    for (int i = 0; i < 6; ++i) {
      const double v = (s.q[i] - prev[i]) / cfg.cycle_s;
      const double a = (s.q[i] - 2 * prev[i] + prev2[i]) / (cfg.cycle_s * cfg.cycle_s);
      r.max_speed_ratio = std::max(r.max_speed_ratio, std::abs(v) / arm.qd_max[i]);
      if (k > 0) r.max_acc_ratio = std::max(r.max_acc_ratio, std::abs(a) / arm.qdd_max[i]);
    }
    const Eigen::Vector3d p = forwardNozzle(arm, s.q).translation();
    r.max_nozzle_speed = std::max(r.max_nozzle_speed, (p - p_prev).norm() / cfg.cycle_s);
    p_prev = p;
    prev2 = prev;
    prev = s.q;
    r.samples.push_back(s);
  }
  std::printf("  max |qd|/qd_max %.3f, max |qdd|/qdd_max %.3f, max nozzle speed %.3f m/s\n", r.max_speed_ratio,
              r.max_acc_ratio, r.max_nozzle_speed);
  return r;
}

}  // namespace

TEST(PreparePlan, FollowsTheCartesianLine) {
  const ArmConfig arm = cellArm();
  const TrajectoryConfig cfg;
  const Workspace ws;
  const Joints q0 = *inverseNozzle(arm, down(-0.1, -0.1, 0.15), arm.q_home);
  const Plan plan = linePlan(1, {{-0.1, -0.1, 0.15}, {0.1, 0.05, 0.1}}, 0.05);
  const PreparedPlan pp = preparePlan(arm, cfg, ws, plan, q0);
  ASSERT_EQ(pp.status, PlanStatus::Accepted) << pp.reason;
  // 0.25 m in steps of at most 1 cm.
  EXPECT_GE(pp.points.size(), 26u);
  const Eigen::Vector3d a(-0.1, -0.1, 0.15), b(0.1, 0.05, 0.1);
  for (const PathPoint& pt : pp.points) {
    const Pose T = forwardNozzle(arm, pt.q);
    // On the segment a-b (distance from the line < 1e-9 m), pointing down.
    const Eigen::Vector3d d = (b - a).normalized();
    const Eigen::Vector3d off = (T.translation() - a) - d * d.dot(T.translation() - a);
    EXPECT_LT(off.norm(), 1e-9);
    EXPECT_LT(rotationAngle(T.linear(), down(0, 0, 0).linear()), 1e-6);
    EXPECT_LE(pt.cart_step, cfg.cartesian_step + 1e-12);
  }
  EXPECT_LT(translationDistance(forwardNozzle(arm, pp.points.back().q), down(0.1, 0.05, 0.1)), 1e-9);
}

TEST(PreparePlan, RefusesBadPlans) {
  const ArmConfig arm = cellArm();
  const TrajectoryConfig cfg;
  const Workspace ws;
  const Joints q0 = *inverseNozzle(arm, down(0, 0, 0.2), arm.q_home);
  // Outside the workspace box (beyond the box wall in x).
  auto pp = preparePlan(arm, cfg, ws, linePlan(1, {{0, 0, 0.2}, {0.3, 0, 0.1}}, 0.05), q0);
  EXPECT_EQ(pp.status, PlanStatus::OutsideWorkspace);
  EXPECT_EQ(pp.bad_waypoint, 1);
  EXPECT_TRUE(pp.points.empty());
  // Below the floor.
  pp = preparePlan(arm, cfg, ws, linePlan(1, {{0, 0, -0.01}}, 0.05), q0);
  EXPECT_EQ(pp.status, PlanStatus::OutsideWorkspace);
  // Unreachable with a tiny workspace-compatible pose: the nozzle pointing straight up at the floor.
  Plan up;
  up.id = 2;
  up.waypoints.push_back({makePoseRpy({0.1, 0, 0.02}, 0, 0, 0), Tool::kOff, 0.05});
  pp = preparePlan(arm, cfg, ws, up, q0);
  EXPECT_EQ(pp.status, PlanStatus::Unreachable);
  // Non-positive and non-finite speeds, invalid pose.
  EXPECT_EQ(preparePlan(arm, cfg, ws, linePlan(3, {{0, 0, 0.1}}, 0.0), q0).status, PlanStatus::InvalidWaypoint);
  EXPECT_EQ(preparePlan(arm, cfg, ws, linePlan(3, {{0, 0, 0.1}}, NAN), q0).status, PlanStatus::InvalidWaypoint);
  Plan bad = linePlan(4, {{0, 0, 0.1}}, 0.05);
  bad.waypoints[0].T_cell_nozzle.linear() *= 1.1;
  EXPECT_EQ(preparePlan(arm, cfg, ws, bad, q0).status, PlanStatus::InvalidWaypoint);
  // No waypoints: a stop request.
  EXPECT_EQ(preparePlan(arm, cfg, ws, Plan{}, q0).status, PlanStatus::Empty);
}

TEST(PreparePlan, ClipsTooFastSpeeds) {
  const ArmConfig arm = cellArm();
  const TrajectoryConfig cfg;
  const Joints q0 = *inverseNozzle(arm, down(0, 0, 0.2), arm.q_home);
  const auto pp = preparePlan(arm, cfg, Workspace(), linePlan(1, {{0, 0, 0.2}, {0.15, 0.1, 0.1}}, 5.0), q0);
  EXPECT_EQ(pp.status, PlanStatus::Clipped);
  EXPECT_EQ(pp.clipped, 2);
  for (const auto& pt : pp.points) EXPECT_EQ(pt.speed, cfg.max_nozzle_speed);
}

// A contour-like plan at the requested speed: limits on every sample, nozzle speed, arrival.
TEST(Trajectory, FollowsPlanWithinLimits) {
  const ArmConfig arm = cellArm();
  const TrajectoryConfig cfg;
  const Joints q0 = *inverseNozzle(arm, down(-0.1, -0.08, 0.12), arm.q_home);
  TrajectoryGenerator gen(arm, cfg);
  gen.reset(q0);
  // A rectangle around a part at 5 cm/s.
  const double v = 0.05;
  const std::vector<Eigen::Vector3d> rect = {
      {-0.1, -0.08, 0.12}, {0.1, -0.08, 0.12}, {0.1, 0.08, 0.12}, {-0.1, 0.08, 0.12}, {-0.1, -0.08, 0.12}};
  const auto pp = preparePlan(arm, cfg, Workspace(), linePlan(7, rect, v), q0);
  ASSERT_TRUE(pp.usable()) << pp.reason;
  gen.setPlan(pp);
  const double length = 2 * (0.2 + 0.16);
  const int cycles = static_cast<int>((length / v + 3.0) / cfg.cycle_s);
  const RunResult r = run(gen, arm, cycles, cfg);
  EXPECT_LE(r.max_speed_ratio, cfg.velocity_scale + 1e-9);
  EXPECT_LE(r.max_acc_ratio, 1.0);
  EXPECT_LE(r.max_nozzle_speed, v * 1.01);
  EXPECT_TRUE(gen.finished());
  EXPECT_LT(translationDistance(forwardNozzle(arm, r.samples.back().q), down(-0.1, -0.08, 0.12)), 1e-9);
  EXPECT_EQ(r.samples.back().plan_id, 7);
  EXPECT_EQ(r.samples.back().waypoint_index, 5);
  EXPECT_EQ(r.samples[10].tool, Tool::kVacuum);
  // Duration: at least length / v, and not much more (stops only at the four corners).
  int moving_cycles = 0;
  for (const auto& s : r.samples) moving_cycles += s.moving ? 1 : 0;
  const double t = moving_cycles * cfg.cycle_s;
  EXPECT_GE(t, length / v - 1e-9);
  EXPECT_LE(t, length / v + 1.0);
  // Straight-edge tracking: mid-edge sample within 1 mm of the line y = -0.08.
  const Eigen::Vector3d mid =
      forwardNozzle(arm, r.samples[static_cast<std::size_t>(0.1 / v / cfg.cycle_s)].q).translation();
  EXPECT_NEAR(mid.y(), -0.08, 1e-3);
  EXPECT_NEAR(mid.z(), 0.12, 1e-3);
}

TEST(Trajectory, FastTransitionIsLimitedByTheJoints) {
  const ArmConfig arm = cellArm();
  TrajectoryConfig cfg;
  cfg.max_nozzle_speed = 5.0;  // let the joints be the limit
  TrajectoryGenerator gen(arm, cfg);
  const Joints q0 = arm.q_home;
  gen.reset(q0);
  const auto pp = preparePlan(arm, cfg, Workspace(), linePlan(1, {{0.15, 0.12, 0.05}, {-0.15, -0.1, 0.3}}, 5.0), q0);
  ASSERT_TRUE(pp.usable()) << pp.reason;
  gen.setPlan(pp);
  const RunResult r = run(gen, arm, 1000, cfg);
  EXPECT_TRUE(gen.finished());
  EXPECT_LE(r.max_speed_ratio, cfg.velocity_scale + 1e-9);
  EXPECT_LE(r.max_acc_ratio, 1.0);
  EXPECT_GT(r.max_nozzle_speed, 0.25);  // genuinely fast
}

TEST(Trajectory, PlanUpdatesAreContinuous) {
  const ArmConfig arm = cellArm();
  TrajectoryConfig cfg;
  cfg.max_nozzle_speed = 1.0;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-0.18, 0.18), uy(-0.13, 0.13), uz(0.02, 0.4), us(0.02, 0.5);
  TrajectoryGenerator gen(arm, cfg);
  gen.reset(arm.q_home);
  int accepted = 0;
  // A new random plan every 5..40 cycles, 2000 cycles: never a jump, never over a limit.
  int next = 0;
  const RunResult r = run(gen, arm, 2000, cfg, [&](int k) {
    if (k != next) return;
    next += 5 + static_cast<int>(rng() % 36);
    std::vector<Eigen::Vector3d> pts;
    for (int i = 0; i < 3; ++i) pts.emplace_back(ux(rng), uy(rng), uz(rng));
    const auto pp = preparePlan(arm, cfg, Workspace(), linePlan(k, pts, us(rng)), gen.current().q);
    if (pp.usable()) {
      gen.setPlan(pp);
      ++accepted;
    }
  });
  EXPECT_GT(accepted, 50);
  EXPECT_LE(r.max_speed_ratio, cfg.velocity_scale + 1e-9);
  EXPECT_LE(r.max_acc_ratio, 1.0);
}

TEST(Trajectory, ControlledStopBrakesAndHolds) {
  const ArmConfig arm = cellArm();
  TrajectoryConfig cfg;
  cfg.max_nozzle_speed = 1.0;
  TrajectoryGenerator gen(arm, cfg);
  gen.reset(arm.q_home);
  const auto pp =
      preparePlan(arm, cfg, Workspace(), linePlan(1, {{0.15, 0.12, 0.05}, {-0.15, -0.1, 0.3}}, 1.0), arm.q_home);
  ASSERT_TRUE(pp.usable());
  gen.setPlan(pp);
  int stopped_at = -1;
  const RunResult r = run(gen, arm, 400, cfg, [&](int k) {
    if (k == 60) gen.stop();
    if (k > 60 && stopped_at < 0 && !gen.current().moving) stopped_at = k;
  });
  ASSERT_GT(stopped_at, 60);
  EXPECT_LT(stopped_at - 60, 100);  // well under a second at these speeds
  EXPECT_LE(r.max_acc_ratio, 1.0);
  EXPECT_FALSE(gen.finished());
  // Holds: the last 100 samples are identical, and the tool is off.
  for (std::size_t k = r.samples.size() - 100; k < r.samples.size(); ++k) {
    EXPECT_EQ(r.samples[k].q, r.samples.back().q);
    EXPECT_EQ(r.samples[k].tool, Tool::kOff);
  }
  // The stop point lies on the planned path (between two IK points, within 1 mm).
  EXPECT_TRUE(Workspace().contains(forwardNozzle(arm, r.samples.back().q).translation(), 1e-3));
}

TEST(Trajectory, EmptyPlanStops) {
  const ArmConfig arm = cellArm();
  const TrajectoryConfig cfg;
  TrajectoryGenerator gen(arm, cfg);
  gen.reset(arm.q_home);
  gen.setPlan(preparePlan(arm, cfg, Workspace(), linePlan(1, {{0.1, 0.1, 0.1}}, 0.2), arm.q_home));
  for (int k = 0; k < 30; ++k) gen.step();
  ASSERT_TRUE(gen.current().moving);
  gen.setPlan(preparePlan(arm, cfg, Workspace(), Plan{}, gen.current().q));
  for (int k = 0; k < 100; ++k) gen.step();
  EXPECT_FALSE(gen.current().moving);
  EXPECT_FALSE(gen.finished());
}

// The driver stops this long (x 1.2, + 2 cycles) before a staleness limit so that the arm is at
// rest by it (driver.cpp, step 5): the estimate must cover the stop as the 8 ms steps brake it,
// a whole number of cycles, including the slow vacuum passes whose stop takes a single cycle.
TEST(Trajectory, BrakingTimeBoundsTheDiscreteStop) {
  const ArmConfig arm = cellArm();
  TrajectoryConfig cfg;
  for (const double speed : {0.01, 0.03, 0.1, 0.3, 1.0}) {
    double under = -1e9, over = -1e9;  // worst (stop - predicted), worst (predicted - stop), s
    int stops = 0;
    for (int at = 5; at < 300; at += 7) {
      TrajectoryGenerator gen(arm, cfg);
      gen.reset(arm.q_home);
      const auto pp =
          preparePlan(arm, cfg, Workspace(), linePlan(1, {{0.15, 0.12, 0.05}, {-0.15, -0.1, 0.3}}, speed), arm.q_home);
      ASSERT_TRUE(pp.usable());
      gen.setPlan(pp);
      for (int k = 0; k < at; ++k) gen.step();
      if (!gen.current().moving) continue;
      const double predicted = gen.brakingTime();
      gen.stop();
      int cycles = 1;  // the cycle that brakes to rest
      while (gen.step().moving) ++cycles;
      under = std::max(under, cycles * cfg.cycle_s - predicted);
      over = std::max(over, predicted - cycles * cfg.cycle_s);
      ++stops;
    }
    std::printf("  nozzle %.2f m/s, %d stops: stop - predicted at most %.4f s, predicted - stop at most %.4f s\n",
                speed, stops, under, over);
    ASSERT_GT(stops, 10);
    EXPECT_LE(under, 1e-9);
    EXPECT_LE(over, 3 * cfg.cycle_s);  // an upper estimate, not an idle one
  }
}
