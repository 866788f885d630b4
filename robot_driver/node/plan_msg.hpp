// NOZZLE_PLAN -> robot::Plan: what depowder-driver does with each plan it receives, before the
// Driver validates the plan itself (reach, workspace, speeds: preparePlan).
#pragma once

#include <string>

#include "depowder/nozzle_plan_t.hpp"
#include "depowder/robot/trajectory.hpp"

namespace depowder::robot {

/// False with `why` if the waypoint count disagrees, a pose is not a valid pose or a tool is
/// unknown (then `plan` is incomplete).
bool fromMsg(const nozzle_plan_t& msg, Plan* plan, std::string* why);

}  // namespace depowder::robot
