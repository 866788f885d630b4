// Physics (issue 4), whole-world outcomes: buried parts stay put, a tall pipe whose powder is removed
// from one side topples to that side and comes to rest, a cube pushed from several contact points
// moves, turns and stops at the wall (paper Fig. 2, Fig. 11, Table II). Outcomes are checked with
// stated margins (fell to the dug side, at the wall within the stop gap).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "depowder/parts.hpp"
#include "depowder/sim/push.hpp"
#include "depowder/sim/world.hpp"
#include "physics_helpers.hpp"

using namespace depowder;
using namespace depowder::sim;
using namespace depowder::sim::test;

TEST(Physics, BuriedPartsDoNotMoveUnderGravity) {
  for (const std::string& name : parts::names()) {
    const Mesh mesh = parts::byName(name);
    // 1 cm of powder under the part, covered 1 cm over its top (the paper's initial state).
    const Pose T0 = at(0.01, -0.02, 0.01 - bounds(mesh).min().z(), 30);
    World world(physicsConfig(), BoxGeometry{}, {{name, mesh, T0, 1000}}, {});
    for (int k = 0; k < 1200; ++k) world.step(kDt);  // 10 s
    const Pose T = world.part(0).T_cell_part;
    EXPECT_LT(translationDistance(T, T0), 0.001) << name;
    EXPECT_LT(rotationAngle(T.linear(), T0.linear()), 0.5 * M_PI / 180) << name;
  }
}

TEST(Physics, TallPipeToppleTowardTheSideItsPowderWasRemovedFrom) {
  // A straight pipe 3 cm wide and 12 cm tall standing on 3 cm of powder, buried; the powder on its
  // +y side is taken away at 10 cm/s down to the floor. Control: the same pipe left alone stands.
  const Mesh pipe = tube(0.015, 0.011, 0.12);
  const Pose T0 = at(0, 0, 0.09);  // on 3 cm of powder
  World world(physicsConfig(), BoxGeometry{}, {{"pipe", pipe, T0, 1000}}, {});
  const Fall fall = digAndWatch(world, 0.0185, 10.0);
  const Eigen::Vector3d u = up(fall.T_end);
  EXPECT_GT(std::acos(std::clamp(u.z(), -1.0, 1.0)) * 180 / M_PI, 60);  // fell
  EXPECT_GT(u.y(), 0.5);                                                // to +y
  EXPECT_GT(u.y(), std::abs(u.x()));
  EXPECT_GT(fall.first_tilt_time, 0);
  EXPECT_GT(fall.rest_time, 0);                           // and lies still
  EXPECT_LT(fall.rest_time - fall.first_tilt_time, 3.0);  // falling takes a few seconds at most
  std::printf("straight pipe: tilted past 5 deg at %.2f s, at rest from %.2f s, up (%.2f %.2f %.2f)\n",
              fall.first_tilt_time, fall.rest_time, u.x(), u.y(), u.z());

  World control(physicsConfig(), BoxGeometry{}, {{"pipe", pipe, T0, 1000}}, {});
  for (int k = 0; k < 1200; ++k) control.step(kDt);
  EXPECT_LT(rotationAngle(control.part(0).T_cell_part.linear(), T0.linear()), 0.5 * M_PI / 180);
}

TEST(Physics, CellPipePerchedOnPowderFallsToTheDugSide) {
  // The default cell's pipe (an elbow) standing on 3 cm of powder, its +y side dug away.
  const Pose T0 = at(0, 0, 0.08);
  World world(physicsConfig(), BoxGeometry{}, {{"pipe", parts::pipe(), T0, 1000}}, {});
  const Fall fall = digAndWatch(world, 0.0185, 8.0);
  const Eigen::Vector3d u = up(fall.T_end);
  EXPECT_GT(u.y(), 0.7);
  EXPECT_LT(u.z(), 0.5);
  EXPECT_GT(fall.T_end.translation().y(), 0.02);
  EXPECT_GT(fall.rest_time, 0);
  EXPECT_LT(fall.rest_time - fall.first_tilt_time, 3.0);
  std::printf("cell pipe: tilted past 5 deg at %.2f s, at rest from %.2f s, up (%.2f %.2f %.2f)\n",
              fall.first_tilt_time, fall.rest_time, u.x(), u.y(), u.z());
}

// --- pushing to the wall (Table II) ---

struct PushCase {
  const char* name;
  Eigen::Vector2d start;  ///< cube centre, m
  double azimuth_deg, offset;
  bool steer;     ///< PushSpec::steer (sliding sideways along the face turns the part too: no sign then)
  int turn_sign;  ///< expected sign of the turn (0: not checked)
};

class PushToWall : public ::testing::TestWithParam<PushCase> {};

TEST_P(PushToWall, CubeMovesTurnsAndStopsAtTheWall) {
  const PushCase& c = GetParam();
  SimConfig config = physicsConfig();
  config.powder.level = 0.03;  // half the cube's height: visibility 0.5
  const Pose T0 = at(c.start.x(), c.start.y(), 0.03);
  World world(config, BoxGeometry{}, {{"cube", parts::cube(), T0, 1000}}, {});
  const double powder0 = world.powderInBox();
  PushSpec spec = pushFrom(world, 0, c.azimuth_deg, 0.5, c.offset);
  spec.speed = 0.03;
  spec.steer = c.steer;
  PushScript push(world, spec);
  bool touched = false;
  double turn = 0;  // deg, summed step by step (a cube's yaw repeats every 90 deg)
  for (int k = 1; k <= 30 * 120 && push.phase() != PushPhase::kDone; ++k) {
    const ArmState a = push.update(k * kDt);
    world.setNozzle(a.T_cell_nozzle, a.tool);
    const double yaw0 = yawDeg(world.part(0).T_cell_part);
    world.step(kDt);
    double d = yawDeg(world.part(0).T_cell_part) - yaw0;
    turn += d - 360 * std::round(d / 360);
    touched = touched || world.partTruth(0).nozzle_contact;
  }
  ASSERT_EQ(push.phase(), PushPhase::kDone) << c.name;
  EXPECT_EQ(push.outcome(), PushOutcome::kReachedWall) << c.name;
  EXPECT_TRUE(touched) << c.name;  // SIM_TRUTH's contact, with the nozzle a kinematic body
  EXPECT_GE(world.truth().contact_count, 1);
  // At the wall it was pushed toward (within the stop gap and a millimetre), and at rest there.
  const Pose T = world.part(0).T_cell_part;
  Eigen::AlignedBox3d b;
  for (const auto& v : world.part(0).mesh.vertices) b.extend(T * v);
  const Eigen::Vector2d dir(-std::cos(c.azimuth_deg * M_PI / 180), -std::sin(c.azimuth_deg * M_PI / 180));
  const Eigen::Vector3d half = 0.5 * world.box().size;
  double gap = 1e9;
  for (int a = 0; a < 2; ++a) {
    if (dir[a] > 0.3) gap = std::min(gap, half[a] - b.max()[a]);
    if (dir[a] < -0.3) gap = std::min(gap, b.min()[a] + half[a]);
  }
  EXPECT_LT(gap, spec.wall_gap + 0.001) << c.name;
  EXPECT_GT(gap, -0.001) << c.name;  // not into the wall
  EXPECT_GT(translationDistance(T, T0), 0.05) << c.name;
  EXPECT_LT(world.partTruth(0).speed, 0.001) << c.name;
  if (c.turn_sign != 0) {
    EXPECT_GT(c.turn_sign * turn, 10.0) << c.name << ": turned " << turn << " deg";
  }
  EXPECT_LT(std::abs(T.translation().z() - T0.translation().z()), 0.003) << c.name;  // slid, did not jump
  // The powder it pushed went somewhere: the powder in the box is kept (gaps under the part refilled).
  EXPECT_NEAR(world.powderInBox(), powder0, powder0 * 0.005) << c.name;
}

INSTANTIATE_TEST_SUITE_P(
    ContactPoints, PushToWall,
    ::testing::Values(PushCase{"centre_from_minus_x", {0.08, 0.0}, 180, 0.0, true, 0},
                      // Left of centre (seen along the push): the part turns clockwise; right: counter-clockwise.
                      PushCase{"left_of_centre", {0.08, 0.0}, 180, 0.01, false, -1},
                      PushCase{"right_of_centre", {0.08, 0.0}, 180, -0.01, false, +1},
                      PushCase{"from_plus_y_steered", {0.0, -0.04}, 90, 0.015, true, 0},
                      PushCase{"diagonal", {-0.1, -0.05}, 45, 0.0, true, 0}),
    [](const ::testing::TestParamInfo<PushCase>& param) { return std::string(param.param.name); });

TEST(Physics, NozzleComesDownBesideAnObliqueFaceAndThePushSlides) {
  // A push 55 deg oblique to the cube's -x face: a nozzle placed radius + gap back along the push
  // line from the contact point would come down on the cube's top edge (which pressed it into the
  // powder and tipped it over before the push began). It must come down beside it, and pushed just
  // above the powder line the cube slides to the wall.
  SimConfig config = physicsConfig();
  config.powder.level = 0.03;  // half the cube's height: visibility 0.5
  const Pose T0 = at(-0.05, -0.05, 0.03);
  World world(config, BoxGeometry{}, {{"cube", parts::cube(), T0, 1000}}, {});
  PushSpec spec;
  spec.contact_part = Eigen::Vector3d(-0.03, 0.0, 0.006);  // 60 % of the height, on the -x face
  spec.direction = Eigen::Vector3d(std::cos(55 * M_PI / 180), std::sin(55 * M_PI / 180), 0);
  spec.speed = 0.02;
  PushScript push(world, spec);
  double max_tilt = 0;
  bool moved_before_push = false;
  for (int k = 1; k <= 30 * 120 && push.phase() != PushPhase::kDone; ++k) {
    const ArmState a = push.update(k * kDt);
    world.setNozzle(a.T_cell_nozzle, a.tool);
    world.step(kDt);
    const Pose& T = world.part(0).T_cell_part;
    if (push.phase() == PushPhase::kDescend)
      moved_before_push = moved_before_push || translationDistance(T, T0) > 0.0005 ||
                          rotationAngle(T.linear(), T0.linear()) > 0.5 * M_PI / 180;
    max_tilt = std::max(max_tilt, std::acos(std::clamp(up(T).z(), -1.0, 1.0)) * 180 / M_PI);
  }
  EXPECT_FALSE(moved_before_push);
  EXPECT_EQ(push.outcome(), PushOutcome::kReachedWall);
  EXPECT_LT(max_tilt, 5.0);  // slid (and turned about the vertical), did not tip
  EXPECT_GT(translationDistance(world.part(0).T_cell_part, T0), 0.08);
  std::printf("oblique push: moved %.1f cm, largest tilt %.2f deg\n",
              100 * translationDistance(world.part(0).T_cell_part, T0), max_tilt);
}
