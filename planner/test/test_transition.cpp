// Waypoint refinement (IK, push, drop, report) and OMPL transitions, verified with the
// independent checker (FCL distance against the true poses).
#include <gtest/gtest.h>

#include "depowder/parts.hpp"
#include "depowder/planner/check.hpp"
#include "depowder/planner/paths.hpp"
#include "depowder/planner/transition.hpp"
#include "depowder/planner/waypoints.hpp"
#include "fixtures.hpp"

using namespace depowder;
using namespace depowder::planner;

namespace {

double maxStep(const robot::Joints& a, const robot::Joints& b) {
  double m = 0;
  for (int i = 0; i < 6; ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

/// Waypoints every ~0.01 rad along a joint path (for the independent check between states).
std::vector<Waypoint> densify(const robot::ArmConfig& arm, const std::vector<robot::Joints>& path) {
  std::vector<Waypoint> out;
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const int n = std::max(1, static_cast<int>(std::ceil(maxStep(path[k], path[k + 1]) / 0.01)));
    for (int j = 0; j < n; ++j) {
      Waypoint w;
      for (int i = 0; i < 6; ++i) w.q[i] = path[k][i] + (path[k + 1][i] - path[k][i]) * j / n;
      w.T_cell_nozzle = robot::forwardNozzle(arm, w.q);
      out.push_back(w);
    }
  }
  return out;
}

class TransitionTest : public ::testing::Test {
 protected:
  PlannerConfig config;
  std::shared_ptr<robot::ArmConfig> arm = test::cellArm();
  // A tall part: a 6 x 12 cm pillar, 30 cm high, standing in the middle of the box.
  Mesh pillar_mesh = parts::box({0.06, 0.12, 0.30});
  Pose T_pillar = makePoseRpy({0.0, 0.0, 0.15}, 0, 0, 0);
  std::unique_ptr<CollisionWorld> world;

  void SetUp() override {
#ifdef DEPOWDER_SANITIZE
    config.transition.time_limit *= 10;  // OMPL's budget: the sanitized build runs about 10 times slower
#endif
    auto pillar = std::make_shared<PartShape>("pillar", pillar_mesh);
    world = std::make_unique<CollisionWorld>(std::vector<std::shared_ptr<const PartShape>>{pillar}, Box{},
                                             config.nozzle, config.collision, arm);
    world->setPart(0, T_pillar, PartState::kTracked);
  }
  robot::Joints ik(const Point& tip) const {
    const auto q = robot::inverseNozzle(*arm, nozzleDown(*arm, tip), arm->q_home);
    EXPECT_TRUE(q);
    return q ? *q : arm->q_home;
  }
};

TEST_F(TransitionTest, OmplGoesAroundATallPart) {
  const robot::Joints start = ik({-0.10, 0.0, 0.10});
  const robot::Joints goal = ik({0.10, 0.0, 0.10});
  ASSERT_FALSE(world->checkArm(start));
  ASSERT_FALSE(world->checkArm(goal));
  // The straight joint-space move would hit the pillar: the test is meaningful.
  bool straight_hits = false;
  for (int k = 0; k <= 100; ++k) {
    robot::Joints q;
    for (int i = 0; i < 6; ++i) q[i] = start[i] + (goal[i] - start[i]) * k / 100;
    straight_hits = straight_hits || world->checkArm(q);
  }
  ASSERT_TRUE(straight_hits);

  const TransitionResult r = planJointPath(*world, start, goal, config.transition, false);
  ASSERT_TRUE(r.ok()) << toString(r.status) << " " << r.reason;
  EXPECT_EQ(r.status, TransitionStatus::kExact);
  EXPECT_EQ(r.ompl_status, "Exact solution");
  EXPECT_LT(r.planning_ms, 1000 * config.transition.time_limit * 2);
  ASSERT_GE(r.path.size(), 3u);
  EXPECT_EQ(r.path.front(), start);
  EXPECT_EQ(r.path.back(), goal);
  for (std::size_t k = 0; k + 1 < r.path.size(); ++k)
    EXPECT_LE(maxStep(r.path[k], r.path[k + 1]), config.transition.waypoint_step + 1e-9);
  // Independent check every 0.01 rad against the true pillar: nothing touches it.
  const CheckReport check =
      checkWaypoints(densify(*arm, r.path), {{"pillar", pillar_mesh, T_pillar}}, Box{}, *arm, config.nozzle);
  EXPECT_EQ(check.in_collision, 0) << check.first;
  EXPECT_GT(check.min_nozzle_part, 0.0);
}

TEST_F(TransitionTest, LiftsOutOfThePowderAndComesDownAtTheGoal) {
  world->setPart(0, T_pillar, PartState::kIgnored);  // only the powder matters here
  world->setPowderTop(0.06);
  const Point a(-0.12, -0.05, 0.03), b(0.05, -0.08, 0.03);  // both in the powder
  const TransitionResult r = planTransition(*world, ik(a), ik(b), config);
  ASSERT_TRUE(r.ok()) << r.reason;
  const double z_safe = safeHeight(*world, config.transition);
  EXPECT_NEAR(z_safe, 0.06 + config.transition.clearance, 1e-9);
  for (const robot::Joints& q : r.path) {
    const Point tip = robot::forwardNozzle(*arm, q).translation();
    const bool over_a = (tip - a).head<2>().norm() < 1e-3, over_b = (tip - b).head<2>().norm() < 1e-3;
    // Below the safe height the nozzle only moves straight up at a or straight down at b.
    if (tip.z() < z_safe - 1e-6) {
      EXPECT_TRUE(over_a || over_b) << tip.transpose();
    }
    EXPECT_FALSE(world->checkArm(q, !(over_a || over_b)));
  }
}

TEST_F(TransitionTest, InvalidGoalIsReported) {
  const robot::Joints start = ik({-0.10, 0.0, 0.10});
  const robot::Joints goal = ik({0.0, 0.0, 0.25});  // nozzle inside the pillar's top
  const TransitionResult r = planJointPath(*world, start, goal, config.transition, false);
  EXPECT_EQ(r.status, TransitionStatus::kInvalidGoal);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(r.path.empty());
  EXPECT_NE(r.reason.find("pillar"), std::string::npos) << r.reason;
}

class RefineTest : public ::testing::Test {
 protected:
  PlannerConfig config;
  std::shared_ptr<robot::ArmConfig> arm = test::cellArm();
  Mesh cube_mesh = parts::byName("cube");
  Pose T_cube = makePoseRpy({0.05, 0.0, 0.03}, 0, 0, 0);
  std::unique_ptr<CollisionWorld> world;
  std::shared_ptr<PartShape> cube = std::make_shared<PartShape>("cube", cube_mesh);

  void SetUp() override {
    world = std::make_unique<CollisionWorld>(std::vector<std::shared_ptr<const PartShape>>{cube}, Box{}, config.nozzle,
                                             config.collision, arm);
    world->setPart(0, T_cube, PartState::kTracked);
  }
  Cloud loop() const {
    const LoopResult l = footprintLoop(*cube, T_cube, 0.05, Point(0, 0, 0.3), config);
    EXPECT_TRUE(l.ok());
    return l.tips;
  }
};

TEST_F(RefineTest, EveryWaypointCarriesItsIkSolution) {
  const Cloud tips = loop();
  const RefinedPath r =
      refinePath(*world, tips, Tool::kVacuum, 0.03, PushMode::kOutward, T_cube.translation(), arm->q_home, config);
  EXPECT_EQ(r.report.kept, static_cast<int>(tips.size())) << r.report.summary();
  ASSERT_EQ(r.pieces.size(), 1u) << r.report.summary();
  for (std::size_t i = 0; i < r.pieces[0].size(); ++i) {
    const Waypoint& w = r.pieces[0][i];
    EXPECT_LT((robot::forwardNozzle(*arm, w.q).translation() - tips[i]).norm(), 1e-6);
    EXPECT_NEAR(w.T_cell_nozzle.linear().col(2).z(), -1.0, 1e-12) << "nozzle points down";
    EXPECT_EQ(w.tool, Tool::kVacuum);
  }
  const CheckReport check = checkWaypoints(r.pieces[0], {{"cube", cube_mesh, T_cube}}, Box{}, *arm, config.nozzle);
  EXPECT_TRUE(check.clean()) << check.first;
}

TEST_F(RefineTest, UnreachableWaypointIsReportedAndDropped) {
  Cloud tips = loop();
  tips.insert(tips.begin() + 5, Point(1.6, 0.0, 0.05));  // 2 m from the base: beyond the arm's reach
  const RefinedPath r =
      refinePath(*world, tips, Tool::kVacuum, 0.03, PushMode::kOutward, T_cube.translation(), arm->q_home, config);
  EXPECT_EQ(r.report.unreachable, 1);
  ASSERT_EQ(r.report.unreachable_indices.size(), 1u);
  EXPECT_EQ(r.report.unreachable_indices[0], 5);
  EXPECT_EQ(r.report.kept, static_cast<int>(tips.size()) - 1);
  EXPECT_NE(r.report.summary().find("1 unreachable"), std::string::npos) << r.report.summary();
  for (const auto& piece : r.pieces)
    for (const Waypoint& w : piece) EXPECT_LT(w.T_cell_nozzle.translation().x(), 0.5);
}

TEST_F(RefineTest, CollidingWaypointIsPushedOutOrDropped) {
  const NozzleConfig& n = config.nozzle;
  const double reach = n.radius + n.margin + config.collision.tracking_margin;
  // 3 mm too close to the cube's +x face (x = 0.08): pushed out along +x.
  const Cloud close{{0.08 + reach - 0.003, 0.0, 0.03}};
  const RefinedPath pushed =
      refinePath(*world, close, Tool::kVacuum, 0.03, PushMode::kOutward, T_cube.translation(), arm->q_home, config);
  ASSERT_EQ(pushed.report.kept, 1) << pushed.report.summary();
  EXPECT_EQ(pushed.report.pushed, 1);
  const double x = pushed.pieces[0][0].T_cell_nozzle.translation().x();
  EXPECT_GE(x, 0.08 + reach);
  EXPECT_LE(x, 0.08 + reach + config.collision.push_step);
  // Inside the part by 2 cm more than max_push can fix: dropped and reported.
  const Cloud deep{{0.06, 0.0, 0.03}};
  const RefinedPath dropped =
      refinePath(*world, deep, Tool::kVacuum, 0.03, PushMode::kOutward, T_cube.translation(), arm->q_home, config);
  EXPECT_EQ(dropped.report.kept, 0);
  EXPECT_EQ(dropped.report.dropped, 1);
  EXPECT_EQ(dropped.report.first_contact, "nozzle-part:cube");
  EXPECT_TRUE(dropped.pieces.empty());
}

}  // namespace
