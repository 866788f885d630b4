#include "planner_node.hpp"

#include <cmath>

#include "depowder/mesh.hpp"
#include "depowder/node/convert.hpp"
#include "driver_config.hpp"

namespace depowder::planner {

namespace {

std::vector<PartSpec> loadParts(const node::CellConfig& cell) {
  std::vector<PartSpec> parts;
  for (const node::PartConfig& p : cell.parts)
    parts.push_back({std::make_shared<PartShape>(p.name, node::loadPartMesh(p)), p.T_cell_part_init});
  return parts;
}

Box boxOf(const node::CellConfig& cell) {
  Box b;
  b.size = cell.box.size;
  b.wall = cell.box.wall;
  return b;
}

}  // namespace

PlannerNodeOptions readPlannerOptions(const node::CellConfig& cell) {
  PlannerNodeOptions o;
  // The arm and the workspace as the driver reads them (one reader for both processes).
  const robot::RobotSection robot = robot::readRobotSection(cell);
  o.arm = robot.driver.arm;
  o.arm_model = robot::armModelId(robot.driver.arm, robot.driver.safety.workspace);
  PlannerConfig& c = o.planner;
  const double ws_margin = robot.driver.safety.workspace_margin;
  c.collision.workspace_min = robot.driver.safety.workspace.min + Eigen::Vector3d::Constant(ws_margin);
  c.collision.workspace_max = robot.driver.safety.workspace.max - Eigen::Vector3d::Constant(ws_margin);

  const node::YamlReader r = cell.root.child("planner");
  const node::YamlReader n = r.child("nozzle");
  n.read("radius", c.nozzle.radius, 0.001, 0.1);
  n.read("length", c.nozzle.length, 0.01, 1.0);
  n.read("margin", c.nozzle.margin, 0.0, 0.05);
  n.finish();
  const node::YamlReader v = r.child("vacuum");
  v.read("standoff", c.vacuum.standoff, 0.005, 0.1);
  v.read("layer_depth", c.vacuum.layer_depth, 0.0, 0.05);
  v.read("speed", c.vacuum.speed, 0.001, 0.5);
  v.read("spacing", c.vacuum.spacing, 0.002, 0.05);
  v.read("min_tip_height", c.vacuum.min_tip_height, 0.0, 0.1);
  v.read("undercut", c.vacuum.undercut, 0.0, 0.2);
  v.read("standoff_tolerance", c.vacuum.standoff_tolerance, 0.0001, 0.005);
  v.read("min_contour_points", c.vacuum.min_contour_points, 3, 10000);
  v.read("counter_clockwise", c.vacuum.counter_clockwise);
  v.finish();
  if (c.vacuum.standoff <= c.nozzle.radius + c.nozzle.margin)
    v.fail("standoff", "must exceed nozzle.radius + nozzle.margin (the nozzle would touch the part)");
  const node::YamlReader b = r.child("blast");
  b.read("standoff", c.blast.standoff, 0.005, 0.2);
  b.read("spacing", c.blast.spacing, 0.002, 0.1);
  b.read("step", c.blast.step, 0.002, 0.1);
  b.read("overhang", c.blast.overhang, 0.0, 0.1);
  b.read("speed", c.blast.speed, 0.001, 0.5);
  b.finish();
  const node::YamlReader k = r.child("collision");
  k.read("tracking_margin", c.collision.tracking_margin, 0.0, 0.05);
  k.read("lost_margin", c.collision.lost_margin, 0.0, 0.1);
  k.read("arm_margin", c.collision.arm_margin, 0.0, 0.1);
  k.read("push_step", c.collision.push_step, 0.0005, 0.02);
  k.read("max_push", c.collision.max_push, 0.0, 0.1);
  k.read("edge_step", c.collision.edge_step, 0.001, 0.05);
  k.read("max_joint_step", c.collision.max_joint_step, 0.01, 1.0);
  k.finish();
  if (c.collision.max_joint_step >= robot.driver.trajectory.max_joint_jump)
    k.fail("max_joint_step", "must be less than robot.max_joint_jump (" +
                                 std::to_string(robot.driver.trajectory.max_joint_jump) +
                                 " rad), or the driver refuses the plans as configuration flips");
  const node::YamlReader t = r.child("transition");
  t.read("time_limit", c.transition.time_limit, 0.01, 10.0);
  t.read("clearance", c.transition.clearance, 0.0, 0.3);
  t.read("speed", c.transition.speed, 0.001, 0.5);
  t.read("check_resolution", c.transition.check_resolution, 0.001, 0.2);
  t.read("waypoint_step", c.transition.waypoint_step, 0.01, 0.5);
  t.read("direct_move", c.transition.direct_move, 0.0, 0.1);
  int seed = static_cast<int>(c.transition.seed);
  t.read("seed", seed, 0, 1 << 30);
  c.transition.seed = static_cast<std::uint32_t>(seed);
  t.finish();
  // The lift's top is transition.clearance over the highest part; the nozzle is checked there grown
  // by its margin and, against a LOST part, lost_margin: with less clearance no move could start.
  if (c.transition.clearance <= c.nozzle.margin + c.collision.lost_margin)
    t.fail("clearance", "must exceed nozzle.margin + collision.lost_margin (" +
                            std::to_string(c.nozzle.margin + c.collision.lost_margin) +
                            " m), or a nozzle lifted over a LOST part is still within its margin");
  const node::YamlReader p = r.child("replan");
  p.read("translation", c.replan.translation, 0.0, 0.1);
  p.read("rotation_deg", c.replan.rotation_deg, 0.0, 90.0);
  p.read("stale_s", c.replan.stale_s, 0.05, 60.0);
  p.read("refresh_s", c.replan.refresh_s, 0.05, 60.0);
  p.read("settle_s", c.replan.settle_s, 0.0, 60.0);
  p.read("moving_translation", c.replan.moving_translation, 0.001, 0.5);
  p.read("moving_rotation_deg", c.replan.moving_rotation_deg, 0.1, 180.0);
  p.finish();
  if (c.replan.refresh_s >= robot.driver.safety.plan_max_age_s)
    p.fail("refresh_s", "must be shorter than robot.plan_max_age, or the driver stops running plans");
  r.read("heartbeat_period", o.heartbeat_period, 0.05, 10.0);
  r.finish();
  return o;
}

nozzle_plan_t toMsg(const Plan& plan) {
  nozzle_plan_t m;
  m.utime = plan.utime;
  m.plan_id = plan.plan_id;
  m.part = plan.part;
  m.phase = static_cast<std::int8_t>(plan.phase);
  m.reason = plan.reason;
  m.num_waypoints = static_cast<std::int32_t>(plan.waypoints.size());
  for (const Waypoint& w : plan.waypoints) {
    waypoint_t wm;
    wm.T_cell_nozzle = node::toMsg(w.T_cell_nozzle);
    wm.tool = static_cast<std::int8_t>(w.tool);
    wm.speed = w.speed;
    for (int i = 0; i < 6; ++i) wm.q[i] = w.q[i];
    m.waypoints.push_back(wm);
  }
  return m;
}

PlannerNode::PlannerNode(const node::CellConfig& cell, const PlannerNodeOptions& options)
    : planner_(loadParts(cell), boxOf(cell), std::make_shared<robot::ArmConfig>(options.arm), options.planner) {}

InputResult PlannerNode::count(InputResult r) {
  if (!r.ok()) {
    ++stats_.rejected;
    stats_.last_rejection = r.reason;
  }
  return r;
}

InputResult PlannerNode::onPose(const part_pose_t& msg, std::int64_t arrival) {
  std::string why;
  const std::optional<Pose> T = node::fromMsg(msg.T_cell_part, &why);
  if (!T) return count({InputStatus::kInvalidPose, "PART_POSE of " + msg.part + ": " + why});
  if (msg.status < part_pose_t::WAITING || msg.status > part_pose_t::LOST)
    return count({InputStatus::kInvalidValue,
                  "PART_POSE of " + msg.part + ": unknown status " + std::to_string(static_cast<int>(msg.status))});
  PoseInput in;
  in.part = msg.part;
  in.utime = msg.utime;
  in.T_cell_part = *T;
  in.status = static_cast<TrackStatus>(msg.status);
  in.status_reason = msg.status_reason;
  return count(planner_.onPose(in, arrival));
}

InputResult PlannerNode::onProgress(const progress_t& msg, std::int64_t arrival) {
  if (msg.status < progress_t::OK || msg.status > progress_t::NO_CONTOUR)
    return count({InputStatus::kInvalidValue,
                  "PROGRESS of " + msg.part + ": unknown status " + std::to_string(static_cast<int>(msg.status))});
  if (msg.num_contour < 0 || msg.num_contour != static_cast<std::int32_t>(msg.contour.size()))
    return count({InputStatus::kInvalidContour, "PROGRESS of " + msg.part + ": num_contour does not match"});
  ProgressInput in;
  in.part = msg.part;
  in.utime = msg.utime;
  in.phase = static_cast<Phase>(msg.phase);
  in.status = static_cast<ProgressStatus>(msg.status);
  in.status_reason = msg.status_reason;
  in.eta = msg.eta;
  in.h_pow = msg.h_pow;
  in.h_max = msg.h_max;
  in.h_min = msg.h_min;
  in.contour.reserve(msg.contour.size());
  for (const auto& p : msg.contour) in.contour.emplace_back(p[0], p[1], p[2]);
  return count(planner_.onProgress(in, arrival));
}

InputResult PlannerNode::onRobot(const robot_state_t& msg) {
  // A driver that has not read the arm over its current connection does not know where it is:
  // before the first read its joints are all 0 (an arm upright, out of the workspace), and a cycle
  // was once planned from there ("hold: the arm is in collision"); a controller refusing the
  // connection (FAULT) or an ESTOP before it are no different. Left out, as the camera proxy's
  // self-filter leaves it out.
  if (!msg.measured) return {};
  RobotInput in;
  in.utime = msg.utime;
  for (int i = 0; i < 6; ++i) in.q[i] = msg.q[i];
  in.plan_id = msg.plan_id;
  in.waypoint_index = msg.waypoint_index;
  in.idle = msg.mode == robot_state_t::MODE_IDLE;
  return count(planner_.onRobot(in));
}

std::optional<nozzle_plan_t> PlannerNode::step() {
  const std::optional<Plan> plan = planner_.step();
  if (!plan) return std::nullopt;
  ++stats_.plans;
  const bool refresh = plan->reason.rfind("refresh: ", 0) == 0;
  if (refresh) {
    ++stats_.refreshes;
  } else {
    stats_.last_planning_ms = plan->planning_ms;
    stats_.last_path_ms = plan->path_ms;
    stats_.last_reason = plan->reason;
  }
  stats_.holding = !plan->hasWaypoints();
  if (stats_.holding) ++stats_.holds;
  return toMsg(*plan);
}

}  // namespace depowder::planner
