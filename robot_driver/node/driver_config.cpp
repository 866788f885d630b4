#include "driver_config.hpp"

#include <cmath>
#include <vector>

namespace depowder::robot {
namespace {

constexpr double kPi = 3.14159265358979323846;

void readJoints(const node::YamlReader& r, const std::string& key, Joints& value, double lo, double hi) {
  if (!r.has(key)) return;
  std::vector<double> v;
  r.read(key, v);
  if (v.size() != 6) r.fail(key, "must be a list of 6 numbers (J1..J6)");
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(v[i]) || v[i] < lo || v[i] > hi)
      r.fail(key, "J" + std::to_string(i + 1) + " = " + std::to_string(v[i]) + " is out of range [" +
                      std::to_string(lo) + ", " + std::to_string(hi) + "]");
    value[i] = v[i];
  }
}

}  // namespace

RobotSection readRobotSection(const node::CellConfig& cell) {
  RobotSection s;
  DriverConfig& d = s.driver;
  const node::YamlReader r = cell.root.child("robot");

  // Controller (b-CAP).
  const node::YamlReader c = r.child("controller");
  c.read("host", d.session.client.host);
  c.read("port", d.session.client.port, 1, 65535);
  c.read("connect_timeout", d.session.client.connect_timeout_s, 0.01, 60.0);
  c.read("reply_timeout", d.session.client.reply_timeout_s, 0.01, 60.0);
  c.read("service_option", d.session.service_option);
  c.read("executing_timeout", d.session.client.executing_timeout_s, 0.1, 600.0);
  c.read("slave_reply_timeout", d.session.slave_reply_timeout_s, 0.004, 1.0);
  c.read("slave_mode", d.session.slave_mode, 0x101, 0x203);
  if ((d.session.slave_mode & 0xFF) != 2 ||
      ((d.session.slave_mode & 0xF00) != 0x100 && (d.session.slave_mode & 0xF00) != 0x200))
    c.fail("slave_mode", "must be 258 (0x102, async joint) or 514 (0x202, sync joint)");
  c.read("controller_name", d.session.controller_name);
  c.read("provider", d.session.provider);
  c.read("machine", d.session.machine);
  c.read("options", d.session.options);
  c.read("robot_name", d.session.robot_name);
  c.read("reconnect_period", d.reconnect_period_s, 0.01, 60.0);
  c.finish();

  // Arm: base pose, tool, limits (rad, rad/s, rad/s^2).
  r.readPose("base_pose", d.arm.T_cell_base);
  r.readPose("tool_offset", d.arm.T_flange_nozzle);
  node::readEffector(r, "effector", d.arm.effector);
  readJoints(r, "q_min", d.arm.q_min, -2 * kPi, 2 * kPi);
  readJoints(r, "q_max", d.arm.q_max, -2 * kPi, 2 * kPi);
  readJoints(r, "qd_max", d.arm.qd_max, 1e-3, 20.0);
  readJoints(r, "qdd_max", d.arm.qdd_max, 1e-3, 200.0);
  readJoints(r, "q_home", d.arm.q_home, -2 * kPi, 2 * kPi);
  const ArmConfig vs6577;  // the manufacturer's ranges: configuration may narrow them, never widen
  for (int i = 0; i < 6; ++i) {
    if (d.arm.q_min[i] < vs6577.q_min[i] - 1e-9 || d.arm.q_max[i] > vs6577.q_max[i] + 1e-9)
      r.fail("q_min", "J" + std::to_string(i + 1) + " limits beyond the VS-6577's own range");
    if (d.arm.q_min[i] >= d.arm.q_max[i]) r.fail("q_max", "J" + std::to_string(i + 1) + ": q_max must exceed q_min");
  }
  if (!withinLimits(d.arm, d.arm.q_home)) r.fail("q_home", "outside q_min / q_max");

  // Trajectory.
  r.read("max_nozzle_speed", d.trajectory.max_nozzle_speed, 0.001, 2.0);
  r.read("max_nozzle_rotation_speed", d.trajectory.max_nozzle_rotation_speed, 0.01, 10.0);
  r.read("velocity_scale", d.trajectory.velocity_scale, 0.01, 1.0);
  r.read("acceleration_scale", d.trajectory.acceleration_scale, 0.01, 1.0);
  r.read("cartesian_step", d.trajectory.cartesian_step, 0.001, 0.1);
  r.read("rotation_step", d.trajectory.rotation_step, 0.005, 0.5);
  r.read("max_joint_jump", d.trajectory.max_joint_jump, 0.01, 3.0);

  // Safety.
  const node::YamlReader w = r.child("workspace");
  w.readVector3("min", d.safety.workspace.min);
  w.readVector3("max", d.safety.workspace.max);
  w.finish();
  if (!(d.safety.workspace.min.array() < d.safety.workspace.max.array()).all())
    r.fail("workspace", "min must be below max on every axis");
  r.read("workspace_margin", d.safety.workspace_margin, 0.0, 0.1);
  r.read("plan_max_age", d.safety.plan_max_age_s, 0.05, 60.0);
  r.read("plan_max_lead", d.safety.plan_max_lead_s, 0.001, 60.0);
  r.read("planner_heartbeat_timeout", d.safety.planner_heartbeat_timeout_s, 0.05, 60.0);
  r.read("require_planner_heartbeat", d.safety.require_planner_heartbeat);
  r.read("limit_tolerance", d.safety.limit_tolerance, 1.0, 1.5);

  // Tool I/O variables (controller I/O through Variable_PutValue).
  const node::YamlReader io = r.child("tool_io");
  io.read("vacuum", d.session.vacuum_variable);
  io.read("air", d.session.air_variable);
  io.finish();

  // The process.
  r.read("state_rate", s.node.state_rate_hz, 125.0, 1000.0);
  r.read("heartbeat_period", s.node.heartbeat_period_s, 0.05, 10.0);
  r.read("planner_process", s.node.planner_process);
  r.read("realtime", s.node.realtime);
  r.finish();
  return s;
}

}  // namespace depowder::robot
