// The driver's safety rules that need no arm: which planner heartbeats count (PlannerWatch) and
// whether a new plan may run (checkNewPlan) or a running one must stop (checkSafety), with the
// times passed in.
#include <gtest/gtest.h>

#include <cmath>

#include "depowder/robot/safety.hpp"

using namespace depowder::robot;

namespace {
const double kNone = std::nan("");  // a heartbeat without the arm_model figure
}

TEST(PlannerWatch, OnePlannerOfThisArm) {
  PlannerWatch w(1234, 1.0);
  EXPECT_EQ(w.heard("compute:10", 1234, false, 0.0), "");
  EXPECT_EQ(w.heard("compute:10", kNone, false, 0.5), "");  // no figure: not checked
  const std::string other = w.heard("compute:10", 999, false, 1.0);
  EXPECT_NE(other.find("another arm or workspace (arm_model 999, this driver's 1234)"), std::string::npos) << other;
  EXPECT_EQ(w.heard("compute:10", 1234, false, 1.5), "");
}

TEST(PlannerWatch, TwoPlannersAtOnceCountAsNone) {
  PlannerWatch w(1, 1.0);
  EXPECT_EQ(w.heard("compute:10", 1, false, 0.0), "");
  const std::string two = w.heard("laptop:77", 1, false, 0.4);
  EXPECT_NE(two.find("2 planners publish plans (compute:10, laptop:77)"), std::string::npos) << two;
  EXPECT_NE(w.heard("compute:10", 1, false, 0.8), "");
  // The laptop's planner stops: its last heartbeat says so, and the one left counts again.
  EXPECT_NE(w.heard("laptop:77", 1, true, 0.9).find("laptop:77 is stopping"), std::string::npos);
  EXPECT_EQ(w.heard("compute:10", 1, false, 1.0), "");
  // A crashed planner (no last word) is forgotten a window after its last heartbeat: a
  // restarted one is refused until then.
  EXPECT_EQ(w.heard("compute:10", 1, false, 2.0), "");
  EXPECT_NE(w.heard("compute:11", 1, false, 2.5), "");
  EXPECT_EQ(w.heard("compute:11", 1, false, 3.1), "");
}

TEST(CheckNewPlan, AgeAgainstThisHostsClock) {
  SafetyConfig c;
  c.plan_max_age_s = 1.5;
  c.plan_max_lead_s = 0.25;
  const std::int64_t now = 1'800'000'000'000'000;  // us
  EXPECT_EQ(checkNewPlan(c, now, now - 1'000'000, 0.1).stop, StopReason::None);
  EXPECT_EQ(checkNewPlan(c, now, now + 200'000, 0.1).stop, StopReason::None);  // clocks a little apart
  EXPECT_EQ(checkNewPlan(c, now, now - 1'600'000, 0.1).stop, StopReason::PlanStale);
  const SafetyVerdict ahead = checkNewPlan(c, now, now + 300'000, 0.1);
  EXPECT_EQ(ahead.stop, StopReason::ClockAhead);
  EXPECT_NE(ahead.reason.find("0.300 s ahead of this host's clock (limit 0.250 s)"), std::string::npos) << ahead.reason;
  EXPECT_EQ(checkNewPlan(c, now, 0, 0.1).stop, StopReason::PlanStale);  // no source time
  // Any utime a NOZZLE_PLAN may carry: its age is taken without overflow (UBSan's check).
  EXPECT_EQ(checkNewPlan(c, now, INT64_MIN, 0.1).stop, StopReason::PlanStale);
  EXPECT_EQ(checkNewPlan(c, now, INT64_MAX, 0.1).stop, StopReason::ClockAhead);
  EXPECT_EQ(checkNewPlan(c, INT64_MIN, INT64_MAX, 0.1).stop, StopReason::ClockAhead);
  EXPECT_EQ(checkNewPlan(c, now, now, 1.1).stop, StopReason::HeartbeatLost);
}

// A plan's age and the planner heartbeat's are held to their limits `stop_lead_s` early, so that
// the arm, braking for that long, is at rest by the limit.
TEST(CheckSafety, AgeLimitsComeTheStopLeadEarly) {
  SafetyConfig c;                                  // plan_max_age 1.5 s, planner_heartbeat_timeout 1.0 s
  const std::int64_t now = 1'800'000'000'000'000;  // us
  SafetyInputs in;
  in.following = true;
  in.now_utime = now;
  in.plan_utime = now - 1'460'000;
  in.heartbeat_age_s = 0.96;
  in.nozzle = Eigen::Vector3d(0, 0, 0.1);
  in.stop_lead_s = 0.03;
  EXPECT_EQ(checkSafety(c, in).stop, StopReason::None);  // 1.49 s and 0.99 s with the lead
  in.plan_utime = now - 1'480'000;
  const SafetyVerdict stale = checkSafety(c, in);
  EXPECT_EQ(stale.stop, StopReason::PlanStale);
  EXPECT_NE(stale.reason.find("plan is 1.510 s old (limit 1.500 s)"), std::string::npos) << stale.reason;
  in.plan_utime = now - 1'460'000;
  in.heartbeat_age_s = 0.975;
  const SafetyVerdict lost = checkSafety(c, in);
  EXPECT_EQ(lost.stop, StopReason::HeartbeatLost);
  EXPECT_NE(lost.reason.find("last planner heartbeat 1.005 s ago (limit 1.000 s)"), std::string::npos) << lost.reason;
  in.stop_lead_s = 0;
  EXPECT_EQ(checkSafety(c, in).stop, StopReason::None);  // without the lead, 25 ms to go
  // Not following a plan: nothing to stop.
  in.heartbeat_age_s = 5;
  in.following = false;
  EXPECT_EQ(checkSafety(c, in).stop, StopReason::None);
  // Leaving the workspace box stops; starting outside it (after a manual move) does not.
  in.following = true;
  in.heartbeat_age_s = 0.1;
  in.nozzle = Eigen::Vector3d(0.3, 0, 0.1);
  EXPECT_EQ(checkSafety(c, in).stop, StopReason::Workspace);
  in.was_inside = false;
  EXPECT_EQ(checkSafety(c, in).stop, StopReason::None);
}

// The last-line limiter: a target beyond the joint limits is clipped to them and reached under
// the speed and acceleration limits; an arm that is outside the limits already (jogged there, or
// limits narrowed in the cell file) is held where it is, and may move back in, never further out
// and never in one cycle (it once jumped to the limit in a single 8 ms step).
TEST(CommandLimiter, OutsideTheLimitsTheArmIsHeldNotPulledIn) {
  const ArmConfig arm;
  const double dt = 0.008, step = arm.qd_max[0] * 1.02 * dt;  // the most one cycle may move J1
  CommandLimiter lim(arm, dt);
  Joints q = arm.q_home;
  q[0] = arm.q_max[0] + 0.1;
  lim.reset(q);
  CommandLimiter::Result r = lim.apply(q);  // hold
  EXPECT_EQ(r.q[0], q[0]);
  Joints further = q;
  further[0] += 0.05;
  r = lim.apply(further);
  EXPECT_EQ(r.q[0], q[0]);
  EXPECT_TRUE(r.clipped_position);
  Joints in = q;
  in[0] = arm.q_max[0] - 0.2;
  double last = q[0];
  for (int k = 0; k < 2000; ++k) {
    r = lim.apply(in);
    ASSERT_LE(std::abs(r.q[0] - last), step + 1e-12) << "cycle " << k;
    ASSERT_LE(r.q[0], q[0]) << "cycle " << k;
    last = r.q[0];
  }
  EXPECT_NEAR(last, in[0], 1e-9);
  // Once inside, the limits hold again.
  Joints out = in;
  out[0] = arm.q_max[0] + 1.0;
  for (int k = 0; k < 2000; ++k) r = lim.apply(out);
  EXPECT_NEAR(r.q[0], arm.q_max[0], 1e-12);
}
