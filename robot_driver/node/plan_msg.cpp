#include "plan_msg.hpp"

#include "depowder/node/convert.hpp"

namespace depowder::robot {

bool fromMsg(const nozzle_plan_t& msg, Plan* plan, std::string* why) {
  plan->id = msg.plan_id;
  plan->utime = msg.utime;
  plan->waypoints.clear();
  if (msg.num_waypoints != static_cast<std::int32_t>(msg.waypoints.size()) || msg.num_waypoints < 0) {
    *why = "num_waypoints disagrees with the waypoints";
    return false;
  }
  for (std::size_t i = 0; i < msg.waypoints.size(); ++i) {
    const waypoint_t& w = msg.waypoints[i];
    std::string pose_why;
    const auto T = node::fromMsg(w.T_cell_nozzle, &pose_why);
    if (!T) {
      *why = "waypoint " + std::to_string(i) + ": " + pose_why;
      return false;
    }
    if (w.tool != waypoint_t::TOOL_OFF && w.tool != waypoint_t::TOOL_VACUUM && w.tool != waypoint_t::TOOL_AIR) {
      *why = "waypoint " + std::to_string(i) + ": unknown tool " + std::to_string(w.tool);
      return false;
    }
    PlanWaypoint pw;
    pw.T_cell_nozzle = *T;
    pw.speed = w.speed;
    pw.tool = static_cast<Tool>(w.tool);
    plan->waypoints.push_back(pw);
  }
  return true;
}

}  // namespace depowder::robot
