// The FCL world: nozzle and arm against parts, walls, floor and powder, at known distances;
// the fast axis distance against FCL's.
#include <gtest/gtest.h>

#include <random>

#include "../src/axis_distance.hpp"
#include "../src/fcl_util.hpp"
#include "depowder/parts.hpp"
#include "depowder/planner/collision.hpp"
#include "depowder/planner/waypoints.hpp"
#include "fixtures.hpp"

using namespace depowder;
using namespace depowder::planner;

namespace {

// FCL's distance from a vertical nozzle axis (tip up to tip + length z) to the part at T: the
// axis as a capsule of negligible radius, solved by GJK. The reference for the planner's field.
double fclAxisDistance(const PartShape& part, const Pose& T, const Point& tip, double length) {
  constexpr double kRadius = 1e-5;
  Pose T_cell_axis = Pose::Identity();
  T_cell_axis.translation() = tip + Point(0, 0, 0.5 * length);
  const FclObject axis(std::make_shared<fcl::Capsuled>(kRadius, length), T_cell_axis);
  const FclObject shape(part.impl().bvh, T);
  fcl::DistanceRequestd request(true);
  fcl::DistanceResultd result;
  fcl::distance(&axis, &shape, request, result);
  return result.min_distance + kRadius;
}

// The planner checks a path's edges on two threads against the same geometries: placing one
// must only read it (an fcl::CollisionObject recomputes the geometry's local box, a write).
TEST(Placed, OnlyReadsTheGeometryAndBoundsItAsFclDoes) {
  auto capsule = prepared(std::make_shared<fcl::Capsuled>(0.04, 0.3));
  Pose T = Pose::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Point(0.1, -0.2, 0.3);
  const Placed rotated = place(capsule, T);
  const FclObject reference(capsule, T);  // rewrites the local box with the same values
  EXPECT_LT((rotated.aabb.min_ - reference.getAABB().min_).norm(), 1e-12);
  EXPECT_LT((rotated.aabb.max_ - reference.getAABB().max_).norm(), 1e-12);
  const Placed upright = place(capsule, Pose(Eigen::Translation3d(0.1, -0.2, 0.3)));
  EXPECT_NEAR(upright.aabb.max_.z() - upright.aabb.min_.z(), 0.3 + 2 * 0.04, 1e-12);  // the tight local box
  EXPECT_NEAR(upright.aabb.min_.x(), 0.1 - 0.04, 1e-12);

  capsule->aabb_radius = 5;  // a sentinel: placing reads it, never recomputes it
  const Placed again = place(capsule, T);
  EXPECT_EQ(capsule->aabb_radius, 5);
  EXPECT_NEAR(again.aabb.max_.x() - again.aabb.min_.x(), 10, 1e-12);
}

TEST(AxisDistance, MatchesFclOnEveryPart) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.09, 0.09), h(-0.02, 0.12);
  for (const std::string& name : parts::names()) {
    const PartShape part(name, parts::byName(name));
    const Pose T = makePoseRpy({0.01, -0.02, 0.05}, 0.3, -0.2, 0.8);
    const AxisDistanceField field(part.mesh(), T, 0.01);
    int compared = 0;
    for (int k = 0; k < 300; ++k) {
      const Point tip(u(rng), u(rng), h(rng));
      const double fcl = fclAxisDistance(part, T, tip, 0.13);
      const auto ours = field.query(tip.x(), tip.y(), tip.z(), tip.z() + 0.13, 0.08);
      if (fcl >= 0.08) {
        EXPECT_TRUE(ours.cut_off || ours.distance >= 0.08 - 1e-6) << name;
        continue;
      }
      if (fcl <= 1e-4) {  // touching: FCL's value is not a distance any more
        EXPECT_LT(ours.distance, 2e-4) << name;
        continue;
      }
      ++compared;
      // FCL's axis is a capsule of radius 1e-5 solved by GJK to 1e-6.
      EXPECT_NEAR(ours.distance, fcl, 2e-5) << name << " tip " << tip.transpose();
      EXPECT_NEAR((ours.on_part - ours.on_axis).norm(), ours.distance, 1e-9);
      EXPECT_NEAR(ours.on_axis.x(), tip.x(), 1e-12);
      EXPECT_GE(ours.on_axis.z(), tip.z() - 1e-12);
      EXPECT_NEAR(distanceToMesh(transformed(part.mesh(), T), ours.on_part), 0.0, 1e-9) << name;
    }
    EXPECT_GT(compared, 100) << name;
  }
}

class WorldTest : public ::testing::Test {
 protected:
  PlannerConfig config;
  std::shared_ptr<robot::ArmConfig> arm = test::cellArm();
  std::shared_ptr<PartShape> cube = std::make_shared<PartShape>("cube", parts::byName("cube"));
  Pose T_cube = makePoseRpy({0.05, 0.0, 0.03}, 0, 0, 0);  // x 0.02..0.08, y -0.03..0.03, z 0..0.06
  std::unique_ptr<CollisionWorld> world;

  void SetUp() override {
    world = std::make_unique<CollisionWorld>(std::vector<std::shared_ptr<const PartShape>>{cube}, Box{}, config.nozzle,
                                             config.collision, arm);
    world->setPart(0, T_cube, PartState::kTracked);
  }
  Pose down(double x, double y, double z) const { return nozzleDown(*arm, {x, y, z}); }
};

TEST_F(WorldTest, NozzleAgainstThePartWithItsMargins) {
  const NozzleConfig& n = config.nozzle;
  const double reach = n.radius + n.margin + config.collision.tracking_margin;  // axis to surface
  const double side = 0.08;                                                     // cube's +x face
  EXPECT_TRUE(world->checkNozzle(down(side + reach - 0.001, 0, 0.03)));
  EXPECT_FALSE(world->checkNozzle(down(side + reach + 0.001, 0, 0.03)));
  EXPECT_EQ(world->checkNozzle(down(side + reach - 0.001, 0, 0.03)).what, "nozzle-part:cube");
  // A LOST part is avoided by the larger margin; an ignored one not at all.
  const double lost_reach = n.radius + n.margin + config.collision.lost_margin;
  world->setPart(0, T_cube, PartState::kLost);
  EXPECT_TRUE(world->checkNozzle(down(side + lost_reach - 0.001, 0, 0.03)));
  EXPECT_FALSE(world->checkNozzle(down(side + lost_reach + 0.001, 0, 0.03)));
  world->setPart(0, T_cube, PartState::kIgnored);
  EXPECT_FALSE(world->checkNozzle(down(0.05, 0, 0.03)));
  // Above the part: the tip may come down to the margins over its top face (z 0.06).
  world->setPart(0, T_cube, PartState::kTracked);
  EXPECT_TRUE(world->checkNozzle(down(0.05, 0, 0.06 + n.margin + config.collision.tracking_margin - 0.001)));
  EXPECT_FALSE(world->checkNozzle(down(0.05, 0, 0.06 + n.margin + config.collision.tracking_margin + 0.001)));
}

TEST_F(WorldTest, NozzleAgainstWallsFloorAndPowder) {
  const NozzleConfig& n = config.nozzle;
  const Box box;
  const double x_wall = 0.5 * box.size.x();
  EXPECT_EQ(world->checkNozzle(down(x_wall - n.radius - n.margin + 0.001, 0.1, 0.1)).what, "nozzle-wall:+x");
  EXPECT_FALSE(world->checkNozzle(down(x_wall - n.radius - n.margin - 0.001, 0.1, 0.1)));
  EXPECT_EQ(world->checkNozzle(down(-0.1, 0.1, n.margin - 0.001)).what, "nozzle-floor");
  EXPECT_FALSE(world->checkNozzle(down(-0.1, 0.1, n.margin + 0.001)));
  world->setPowderTop(0.08);
  EXPECT_FALSE(world->checkNozzle(down(-0.1, 0.1, 0.05)));
  EXPECT_EQ(world->checkNozzle(down(-0.1, 0.1, 0.05), true).what, "nozzle-powder");
  EXPECT_FALSE(world->checkNozzle(down(-0.1, 0.1, 0.08 + n.margin + 0.001), true));
}

TEST_F(WorldTest, ArmLinksAndLimits) {
  EXPECT_FALSE(world->checkArm(arm->q_home)) << world->checkArm(arm->q_home).what;
  robot::Joints q = arm->q_home;
  q[1] = arm->q_max[1] + 0.01;
  EXPECT_EQ(world->checkArm(q).what, "joint limits");
  // The nozzle into the part through IK: the arm check sees the nozzle collision.
  const auto inside = robot::inverseNozzle(*arm, down(0.05, 0, 0.065), arm->q_home);
  ASSERT_TRUE(inside);
  EXPECT_EQ(world->checkArm(*inside).what, "nozzle-part:cube");
  // Reaching down at the far wall puts the forearm on the rim.
  const auto far = robot::inverseNozzle(*arm, down(0.19, 0.0, 0.02), arm->q_home);
  ASSERT_TRUE(far);
  const Contact c = world->checkArm(*far);
  EXPECT_TRUE(c);
  EXPECT_NE(c.what.find("wall:+x"), std::string::npos) << c.what;
}

}  // namespace
