// The simulated arm's meshes: the end effector's cylinders are closed, wound outward and where
// the tool says (on the tool axis from the flange, one after the other).
#include <gtest/gtest.h>

#include <cmath>

#include "../app/emulated_arm.hpp"

using namespace depowder;

TEST(EmulatedArm, EffectorCylindersAreClosedOutwardAndOnTheToolAxis) {
  robot::ArmConfig arm;
  arm.T_flange_nozzle.translation() = Eigen::Vector3d(0, 0, 0.25);
  const std::vector<EffectorBody> bodies = effectorBodies(arm.effector, arm.T_flange_nozzle);
  ASSERT_EQ(bodies.size(), 2u);      // the plate on the flange, then the body
  const sim::BcapEmulator emulator;  // not started: only the arm's meshes are wanted
  const sim::EmulatedArm emulated(emulator, arm);
  ASSERT_EQ(emulated.linkMeshes().size(), robot::linkCapsules().size() + 2);  // the links, then the effector
  const int segments = 16;
  double from = 0;
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    const EffectorBody& body = bodies[k];
    const Mesh& m = emulated.linkMeshes()[robot::linkCapsules().size() + k];
    EXPECT_EQ(closednessProblem(m, true), "");
    // Outward: the volume of the inscribed prism, positive.
    const double prism = 0.5 * segments * body.radius * body.radius * std::sin(2 * M_PI / segments) * body.length;
    EXPECT_NEAR(volume(m), prism, 1e-9);
    // From where the one before ends along the tool, within the radius of the axis.
    const Eigen::AlignedBox3d box = bounds(m);
    EXPECT_NEAR(box.min().z(), from, 1e-12);
    EXPECT_NEAR(box.max().z(), from + body.length, 1e-12);
    EXPECT_NEAR(box.max().x(), body.radius, 1e-12);
    from += body.length;
  }
  EXPECT_NEAR(from, 0.129, 1e-12);  // the authors' end effector, 12.9 cm
  EXPECT_NEAR(bodies[0].radius, 0.0445, 1e-12);
}
