// The `robot` section of the default cell: it loads, it is consistent, and its base pose lets
// the nozzle reach the whole box interior pointing down (IK over a grid); bad values are refused.
// And NOZZLE_PLAN -> Plan.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "driver_config.hpp"
#include "plan_msg.hpp"

using namespace depowder;
using namespace depowder::robot;

namespace {
constexpr double kPi = 3.14159265358979323846;

node::CellConfig defaultCell() { return node::loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml"); }

void expectError(const std::string& robot_yaml, const std::string& needle) {
  const std::string yaml = "robot:\n" + robot_yaml;
  try {
    readRobotSection(node::loadCellFromString(yaml, "bad.yaml"));
    ADD_FAILURE() << "accepted:\n" << yaml;
  } catch (const node::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(DriverConfig, DefaultCellRobotSection) {
  const node::CellConfig cell = defaultCell();
  const RobotSection s = readRobotSection(cell);
  EXPECT_EQ(s.driver.session.client.host, "127.0.0.1");
  EXPECT_EQ(s.driver.session.client.port, 5007);
  EXPECT_EQ(s.driver.session.slave_mode, 0x202);
  EXPECT_NEAR(s.driver.arm.T_flange_nozzle.translation().z(), 0.25, 1e-12);  // end effector + tube
  ASSERT_EQ(s.driver.arm.effector.size(), 2u);                               // the end effector's body:
  EXPECT_DOUBLE_EQ(s.driver.arm.effector[0].radius, 0.0445);                 // its plate on the flange
  EXPECT_DOUBLE_EQ(s.driver.arm.effector[1].length, 0.121);                  // and the rest
  EXPECT_GE(s.node.state_rate_hz, 125.0);
  EXPECT_EQ(s.driver.session.vacuum_variable, "IO24");
  EXPECT_DOUBLE_EQ(s.driver.safety.plan_max_age_s, 1.5);
  EXPECT_DOUBLE_EQ(s.driver.safety.plan_max_lead_s, 0.25);
  // Home: within limits, nozzle inside the workspace, pointing down.
  const Pose home = forwardNozzle(s.driver.arm, s.driver.arm.q_home);
  EXPECT_TRUE(s.driver.safety.workspace.contains(home.translation()));
  EXPECT_LT((home.linear() * Eigen::Vector3d::UnitZ()).z(), -0.99);
  // The workspace covers the box interior (from the shared box section).
  const Eigen::Vector3d half = 0.5 * cell.box.size;
  EXPECT_LE(s.driver.safety.workspace.min.x(), -half.x() + 1e-9);
  EXPECT_GE(s.driver.safety.workspace.max.x(), half.x() - 1e-9);
  EXPECT_LE(s.driver.safety.workspace.min.y(), -half.y() + 1e-9);
  EXPECT_GE(s.driver.safety.workspace.max.y(), half.y() - 1e-9);
  EXPECT_GE(s.driver.safety.workspace.max.z(), cell.box.size.z());
}

// Every point of a 1 cm grid over the box interior (up to 10 cm above its rim) is reachable
// with the nozzle pointing straight down, in 4 headings about the vertical.
TEST(DriverConfig, BasePoseReachesTheWholeBoxPointingDown) {
  const node::CellConfig cell = defaultCell();
  const ArmConfig arm = readRobotSection(cell).driver.arm;
  const Eigen::Vector3d size = cell.box.size;
  int n = 0, failed = 0;
  Joints seed = arm.q_home;
  for (double x = -size.x() / 2; x <= size.x() / 2 + 1e-9; x += 0.01)
    for (double y = -size.y() / 2; y <= size.y() / 2 + 1e-9; y += 0.01)
      for (double z = 0.0; z <= size.z() + 0.1 + 1e-9; z += 0.02)
        for (double heading : {0.0, kPi / 2, kPi, -kPi / 2}) {
          const Pose T = makePoseRpy({x, y, z}, 0, kPi, heading);
          const auto q = inverseNozzle(arm, T, seed);
          ++n;
          if (!q) {
            ++failed;
            continue;
          }
          EXPECT_LT(translationDistance(forwardNozzle(arm, *q), T), 1e-6);
        }
  EXPECT_EQ(failed, 0) << "of " << n;
  EXPECT_GT(n, 10000);
}

// The planner and the driver each read their own host's cell file; armModelId is what the driver
// compares. It follows the arm and workspace values, not the file's text or other settings.
TEST(DriverConfig, ArmModelIdFollowsTheArmOnly) {
  auto idOf = [](const std::string& robot_yaml) {
    const RobotSection s = readRobotSection(node::loadCellFromString("robot:\n" + robot_yaml));
    return armModelId(s.driver.arm, s.driver.safety.workspace);
  };
  const RobotSection def = readRobotSection(defaultCell());
  const double id = armModelId(def.driver.arm, def.driver.safety.workspace);
  EXPECT_EQ(id, std::floor(id));
  EXPECT_GE(id, 0);
  EXPECT_LT(id, 4503599627370496.0);  // 2^52: exact in a heartbeat stat
  const double base = idOf("  base_pose: {xyz: [-0.55, 0.0, 0.0], rpy_deg: [0, 0, 0]}\n");
  EXPECT_EQ(base, idOf("  base_pose:\n    xyz: [-0.550, 0, 0.0]   # the same values\n    rpy_deg: [0, 0, 0]\n"));
  EXPECT_EQ(base, idOf("  base_pose: {xyz: [-0.55, 0.0, 0.0], rpy_deg: [0, 0, 0]}\n  controller: {host: 10.0.0.7}\n"));
  EXPECT_NE(base, idOf("  base_pose: {xyz: [-0.551, 0.0, 0.0], rpy_deg: [0, 0, 0]}\n"));
  EXPECT_NE(base, idOf("  base_pose: {xyz: [-0.55, 0.0, 0.0], rpy_deg: [0, 0, 0.1]}\n"));
  EXPECT_NE(base, idOf("  base_pose: {xyz: [-0.55, 0.0, 0.0], rpy_deg: [0, 0, 0]}\n  tool_offset: {xyz: [0, 0, 0.26], "
                       "rpy_deg: [0, 0, 0]}\n"));
  EXPECT_NE(base, idOf("  base_pose: {xyz: [-0.55, 0.0, 0.0], rpy_deg: [0, 0, 0]}\n  workspace: {min: [-0.2, -0.15, "
                       "0.0], max: [0.2, 0.15, 0.5]}\n"));
  EXPECT_NE(base, idOf("  base_pose: {xyz: [-0.55, 0.0, 0.0], rpy_deg: [0, 0, 0]}\n  effector: [{radius: 0.03, length: "
                       "0.1}]\n"));
}

// robot.effector: an empty list is a bare nozzle (no end effector's body); a null or absent key
// keeps the authors' end effector.
TEST(DriverConfig, EffectorEmptyNullOrAbsent) {
  auto effector = [](const std::string& robot_yaml) {
    return readRobotSection(node::loadCellFromString("robot:\n" + robot_yaml, "effector.yaml")).driver.arm.effector;
  };
  EXPECT_TRUE(effector("  effector: []\n").empty());
  EXPECT_EQ(effector("  effector:\n").size(), 2u);
  EXPECT_EQ(effector("  state_rate: 125\n").size(), 2u);
  const auto one = effector("  effector: [{radius: 0.03, length: 0.1}]\n");
  ASSERT_EQ(one.size(), 1u);
  EXPECT_DOUBLE_EQ(one[0].radius, 0.03);
  EXPECT_DOUBLE_EQ(one[0].length, 0.1);
}

TEST(DriverConfig, RefusesBadValues) {
  expectError("  bogus: 1\n", "bogus");
  expectError("  plan_max_lead: 0\n", "plan_max_lead");
  expectError("  controller: {port: 0}\n", "port");
  expectError("  controller: {slave_mode: 513}\n", "slave_mode");
  expectError("  q_min: [0, 0, 0]\n", "6 numbers");
  expectError("  q_max: [3.2, 2.356194, 2.949606, 3.316126, 2.094395, 6.283185]\n", "VS-6577");
  expectError("  q_home: [0, -1.9, 0, 0, 0, 0]\n", "q_home");
  expectError("  workspace: {min: [0, 0, 0], max: [0.1, -0.1, 0.1]}\n", "workspace");
  expectError("  state_rate: 50\n", "state_rate");
  expectError("  tool_io: {vacuum: IO24, water: IO26}\n", "water");
  expectError("  tool_radius: 0.045\n", "tool_radius");  // the single cylinder's key before robot.effector
  expectError("  effector: [{radius: 0.03}]\n", "robot.effector[0].length");
  expectError("  effector: [{radius: 0.03, length: -0.1}]\n", "(0, 2] m");
  expectError("  effector: [{radius: .nan, length: 0.1}]\n", "radius");
  expectError("  effector: [{radius: 0.03, length: 0.1, colour: red}]\n", "colour");
  expectError("  effector: {radius: 0.03, length: 0.1}\n", "must be a list");
}

// NOZZLE_PLAN -> Plan (plan_msg.hpp): what the driver refuses before preparePlan sees a plan.
TEST(PlanMsg, ConvertsWaypointsAndRefusesWhatIsMalformed) {
  nozzle_plan_t msg;
  msg.plan_id = 7;
  msg.utime = 123;
  waypoint_t w;
  w.T_cell_nozzle = node::toMsg(makePose(Eigen::Vector3d(0.1, 0, 0.2), Eigen::Quaterniond(0, 1, 0, 0)));
  w.tool = waypoint_t::TOOL_AIR;
  w.speed = 0.05;
  msg.waypoints = {w, w};
  msg.num_waypoints = 2;
  Plan plan;
  std::string why;
  ASSERT_TRUE(fromMsg(msg, &plan, &why)) << why;
  EXPECT_EQ(plan.id, 7);
  EXPECT_EQ(plan.utime, 123);
  ASSERT_EQ(plan.waypoints.size(), 2u);
  EXPECT_EQ(plan.waypoints[1].tool, Tool::kAir);
  EXPECT_DOUBLE_EQ(plan.waypoints[1].speed, 0.05);
  EXPECT_NEAR((plan.waypoints[1].T_cell_nozzle.translation() - Eigen::Vector3d(0.1, 0, 0.2)).norm(), 0, 1e-12);

  nozzle_plan_t bad = msg;
  bad.num_waypoints = 3;
  EXPECT_FALSE(fromMsg(bad, &plan, &why));
  EXPECT_EQ(why, "num_waypoints disagrees with the waypoints");
  bad = msg;
  bad.waypoints[1].T_cell_nozzle.position[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(fromMsg(bad, &plan, &why));
  EXPECT_EQ(why, "waypoint 1: pose has NaN or infinite values");
  bad = msg;
  bad.waypoints[0].tool = 9;
  EXPECT_FALSE(fromMsg(bad, &plan, &why));
  EXPECT_EQ(why, "waypoint 0: unknown tool 9");
}
