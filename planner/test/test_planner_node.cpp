// depowder-planner's message layer without a network: the YAML section, message conversion,
// bad messages rejected with a reason, plans on the wire carrying IK solutions.
#include <gtest/gtest.h>

#include <cmath>

#include "cube_messages.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/parts.hpp"
#include "driver_config.hpp"
#include "planner_node.hpp"

using namespace depowder;
using namespace depowder::planner;

namespace {

void expectError(const std::string& planner_section, const std::string& needle) {
  try {
    readPlannerOptions(node::loadCellFromString(test::cubeCellYaml(planner_section), "bad.yaml"));
    ADD_FAILURE() << "accepted:\n" << planner_section;
  } catch (const node::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
  }
}

TEST(PlannerOptions, DefaultCellSectionMatchesTheStructDefaults) {
  const node::CellConfig cell = node::loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml");
  const PlannerNodeOptions o = readPlannerOptions(cell);
  const PlannerConfig d;
  EXPECT_EQ(o.planner.vacuum.standoff, d.vacuum.standoff);
  EXPECT_EQ(o.planner.vacuum.layer_depth, d.vacuum.layer_depth);
  EXPECT_EQ(o.planner.blast.standoff, d.blast.standoff);
  EXPECT_EQ(o.planner.transition.time_limit, d.transition.time_limit);
  EXPECT_EQ(o.planner.replan.refresh_s, d.replan.refresh_s);
  EXPECT_EQ(o.planner.nozzle.radius, d.nozzle.radius);
  EXPECT_EQ(o.planner.collision.max_joint_step, d.collision.max_joint_step);
  // The workspace is the driver's, less its margin.
  EXPECT_NEAR(o.planner.collision.workspace_max.x(), 0.195, 1e-12);
  EXPECT_NEAR(o.planner.collision.workspace_min.y(), -0.145, 1e-12);
  // The arm_model of its heartbeat is what the driver reading the same file computes for itself.
  const robot::RobotSection robot = robot::readRobotSection(cell);
  EXPECT_EQ(o.arm_model, robot::armModelId(robot.driver.arm, robot.driver.safety.workspace));
  EXPECT_GT(o.arm_model, 0);
}

TEST(PlannerOptions, RejectsUnknownKeysAndBadValues) {
  expectError("planner:\n  vacuum: {standof: 0.02}\n", "standof");
  expectError("planner:\n  vacuum: {standoff: 0.5}\n", "standoff");
  expectError("planner:\n  vacuum: {standoff: 0.012}\n", "nozzle.radius");
  expectError("planner:\n  replan: {refresh_s: 2.0}\n", "plan_max_age");
  expectError("planner:\n  colour: red\n", "colour");
  expectError("planner:\n  transition: {clearance: 0.02}\n",
              "must exceed nozzle.margin + collision.lost_margin (0.022500");
  // The driver refuses a joint change over robot.max_joint_jump between IK points as a branch flip.
  expectError("planner:\n  collision: {max_joint_step: 0.4}\n", "must be less than robot.max_joint_jump (0.350000");
}

class NodeTest : public ::testing::Test {
 protected:
  node::CellConfig cell = node::loadCellFromString(test::cubeCellYaml(), "test.yaml");
  PlannerNodeOptions options = readPlannerOptions(cell);
  PlannerNode node{cell, options};
  std::int64_t utime = 5000000;  ///< also when the messages arrive
};

TEST_F(NodeTest, PlanOnTheWireCarriesIkSolutionsAndTheFrameUtime) {
  const Pose T = makePoseRpy({0.02, 0.01, 0.03}, 0, 0, 0.3);
  ASSERT_TRUE(node.onPose(test::cubePose(utime, T), utime).ok());
  ASSERT_TRUE(node.onProgress(test::cubeProgress(utime, T, 0.04), utime).ok());
  const auto msg = node.step();
  ASSERT_TRUE(msg);
  EXPECT_EQ(msg->utime, utime);
  EXPECT_EQ(msg->part, "cube");
  EXPECT_EQ(msg->phase, +progress_t::PHASE_VACUUM_TRACKED);
  ASSERT_GT(msg->num_waypoints, 20);
  ASSERT_EQ(msg->num_waypoints, static_cast<std::int32_t>(msg->waypoints.size()));
  int vacuum = 0;
  for (const waypoint_t& w : msg->waypoints) {
    const auto T_w = node::fromMsg(w.T_cell_nozzle);
    ASSERT_TRUE(T_w);
    const robot::Joints q{w.q[0], w.q[1], w.q[2], w.q[3], w.q[4], w.q[5]};
    EXPECT_LT((robot::forwardNozzle(options.arm, q).translation() - T_w->translation()).norm(), 1e-5);
    EXPECT_GT(w.speed, 0.0);
    if (w.tool == waypoint_t::TOOL_VACUUM) ++vacuum;
  }
  EXPECT_GT(vacuum, 20);
  EXPECT_EQ(node.stats().plans, 1);
  EXPECT_FALSE(node.step()) << "nothing changed";
}

TEST_F(NodeTest, BadMessagesAreRejectedWithAReason) {
  part_pose_t bad = test::cubePose(utime, Pose::Identity());
  bad.T_cell_part.position[0] = std::nan("");
  const InputResult r = node.onPose(bad, utime);
  EXPECT_EQ(r.status, InputStatus::kInvalidPose);
  EXPECT_NE(r.reason.find("cube"), std::string::npos) << r.reason;
  part_pose_t unnormalised = test::cubePose(utime, Pose::Identity());
  unnormalised.T_cell_part.orientation[0] = 2.0;
  EXPECT_EQ(node.onPose(unnormalised, utime).status, InputStatus::kInvalidPose);
  progress_t empty = test::cubeProgress(utime, Pose::Identity(), 0.04);
  empty.contour.clear();
  empty.num_contour = 0;
  const InputResult e = node.onProgress(empty, utime);
  EXPECT_EQ(e.status, InputStatus::kInvalidContour);
  EXPECT_NE(e.reason.find("0 points"), std::string::npos) << e.reason;
  progress_t mismatch = test::cubeProgress(utime, Pose::Identity(), 0.04);
  mismatch.num_contour = 3;
  EXPECT_EQ(node.onProgress(mismatch, utime).status, InputStatus::kInvalidContour);
  robot_state_t robot{};
  robot.measured = true;
  robot.q[2] = std::nan("");
  EXPECT_EQ(node.onRobot(robot).status, InputStatus::kInvalidValue);
  EXPECT_EQ(node.stats().rejected, 5);
  // Nothing valid: a hold with no waypoints and a reason.
  const auto msg = node.step();
  ASSERT_TRUE(msg);
  EXPECT_EQ(msg->num_waypoints, 0);
  EXPECT_NE(msg->reason.find("hold"), std::string::npos) << msg->reason;
  EXPECT_TRUE(node.stats().holding);
}

TEST_F(NodeTest, AnUnmeasuredDriversJointsAreNotTheArms) {
  // Before its first read of the arm the driver publishes ROBOT_STATE with joints all 0, whether
  // it has no connection (DISCONNECTED) or the controller refused it (FAULT); the planner once
  // planned from them and held ("the arm is in collision (workspace)").
  robot_state_t robot{};
  robot.utime = utime;
  robot.mode = robot_state_t::MODE_DISCONNECTED;
  robot.plan_id = -1;
  ASSERT_TRUE(node.onRobot(robot).ok());
  robot.mode = robot_state_t::MODE_FAULT;
  ASSERT_TRUE(node.onRobot(robot).ok());
  const Pose T = makePoseRpy({0.02, 0.01, 0.03}, 0, 0, 0.3);
  ASSERT_TRUE(node.onPose(test::cubePose(utime, T), utime).ok());
  ASSERT_TRUE(node.onProgress(test::cubeProgress(utime, T, 0.04), utime).ok());
  const auto msg = node.step();
  ASSERT_TRUE(msg);
  EXPECT_GT(msg->num_waypoints, 20) << msg->reason;
  // The plan a planner that never heard ROBOT_STATE makes (from the home joints).
  PlannerNode unheard{cell, options};
  ASSERT_TRUE(unheard.onPose(test::cubePose(utime, T), utime).ok());
  ASSERT_TRUE(unheard.onProgress(test::cubeProgress(utime, T, 0.04), utime).ok());
  const auto expected = unheard.step();
  ASSERT_TRUE(expected);
  ASSERT_EQ(msg->num_waypoints, expected->num_waypoints);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(msg->waypoints[0].q[i], expected->waypoints[0].q[i]);
  EXPECT_EQ(node.stats().rejected, 0);
}

TEST_F(NodeTest, NoPoseProgressWithNaNHeightsIsAccepted) {
  // The estimator sends NaN heights without a contour; that is a state, not a bad message.
  progress_t m = test::cubeProgress(utime, Pose::Identity(), 0.04);
  m.status = progress_t::NO_POSE;
  m.h_pow = m.h_max = m.h_min = std::nan("");
  m.contour.clear();
  m.num_contour = 0;
  EXPECT_TRUE(node.onProgress(m, utime).ok());
}

}  // namespace
