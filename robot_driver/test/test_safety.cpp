// The driver's safety rules that need no arm: which planner heartbeats count (PlannerWatch) and
// whether a new plan may run (checkNewPlan), with the times passed in.
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
  EXPECT_EQ(checkNewPlan(c, now, now, 1.1).stop, StopReason::HeartbeatLost);
}
