// Moves between path pieces, between parts and to / from home, planned in joint space
// (6-DOF, the VS-6577's joint limits) with OMPL's RRTConnect and path simplification; the
// validity checker is CollisionWorld::checkArm (FCL). OMPL stays behind this header.
#pragma once

#include <string>
#include <vector>

#include "depowder/planner/collision.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/planner/waypoints.hpp"
#include "depowder/robot/kinematics.hpp"

namespace depowder::planner {

/// The outcome of a joint-space query; kExact .. kFailed mirror ompl::base::PlannerStatus.
enum class TransitionStatus {
  kDirect,        ///< the straight joint-space line was free: OMPL not needed
  kExact,         ///< OMPL EXACT_SOLUTION
  kApproximate,   ///< OMPL APPROXIMATE_SOLUTION (not used: it does not reach the goal)
  kTimeout,       ///< OMPL TIMEOUT: no path within the time limit
  kInvalidStart,  ///< start in collision or outside the joint limits
  kInvalidGoal,   ///< goal in collision or outside the joint limits
  kBlocked,       ///< the vertical lift out of (or descent into) the powder is blocked
  kFailed,        ///< any other OMPL status (CRASH, ABORT, ...)
};
const char* toString(TransitionStatus s);

struct TransitionResult {
  TransitionStatus status = TransitionStatus::kFailed;
  std::string ompl_status;          ///< ompl::base::PlannerStatus as text; "" when OMPL did not run
  std::string reason;               ///< what failed, when !ok()
  std::vector<robot::Joints> path;  ///< start .. goal, no joint moving more than waypoint_step per step
  double planning_ms = 0;           ///< wall time of the query
  bool ok() const { return status == TransitionStatus::kDirect || status == TransitionStatus::kExact; }
};

/// A collision-free joint-space path from start to goal: the straight line if it is free
/// (and `try_direct`), else RRTConnect + simplification within config.time_limit.
TransitionResult planJointPath(const CollisionWorld& world, const robot::Joints& start, const robot::Joints& goal,
                               const TransitionConfig& config, bool include_powder, bool try_direct = true);

/// Height the nozzle tip travels at between parts: above every part's top and the powder
/// (world.powderTop()), plus transition.clearance.
double safeHeight(const CollisionWorld& world, const TransitionConfig& config);

/// A tool-off move from one waypoint's joints to another's: straight up along the nozzle
/// axis to safeHeight (out of the powder), a joint-space path that avoids the powder, and
/// straight down. Lift and descent are skipped for ends already above the safe height.
TransitionResult planTransition(const CollisionWorld& world, const robot::Joints& start, const robot::Joints& goal,
                                const PlannerConfig& config, bool try_direct = true);

/// Tool-off waypoints along a joint path (without its first state, where the arm already is).
std::vector<Waypoint> pathWaypoints(const robot::ArmConfig& arm, const std::vector<robot::Joints>& path, double speed);

}  // namespace depowder::planner
