// The simulated arm's meshes: the end effector's cylinder is closed, wound outward and where
// the tool says (on the tool axis from the flange).
#include <gtest/gtest.h>

#include <cmath>

#include "../app/emulated_arm.hpp"

using namespace depowder;

TEST(EmulatedArm, EffectorCylinderIsClosedOutwardAndOnTheToolAxis) {
  robot::ArmConfig arm;
  arm.T_flange_nozzle.translation() = Eigen::Vector3d(0, 0, 0.25);
  const robot::EffectorBody body = robot::effectorBody(arm);
  const sim::BcapEmulator emulator;  // not started: only the arm's meshes are wanted
  const sim::EmulatedArm emulated(emulator, arm);
  ASSERT_EQ(emulated.linkMeshes().size(), robot::linkCapsules().size() + 1);  // the links, then the effector
  const int segments = 16;
  const Mesh& m = emulated.linkMeshes().back();
  EXPECT_EQ(closednessProblem(m, true), "");
  // Outward: the volume of the inscribed prism, positive.
  const double prism = 0.5 * segments * body.radius * body.radius * std::sin(2 * M_PI / segments) * body.length;
  EXPECT_NEAR(volume(m), prism, 1e-9);
  // From the flange (z = 0) to 12.9 cm along the tool, within the radius of the axis.
  const Eigen::AlignedBox3d box = bounds(m);
  EXPECT_NEAR(box.min().z(), 0.0, 1e-12);
  EXPECT_NEAR(box.max().z(), 0.129, 1e-12);
  EXPECT_NEAR(box.max().x(), 0.045, 1e-12);
}
