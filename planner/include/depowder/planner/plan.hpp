// One plan = one cycle on one part (paper Sec. III-B and the two-cube demo: one loop or
// one raster pass on a part, then the next part): the phase's path, refined to reachable,
// collision-free waypoints, entered from where the nozzle is and with its pieces joined by
// transitions. Also the move home.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/planner/collision.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/planner/paths.hpp"
#include "depowder/planner/transition.hpp"
#include "depowder/planner/waypoints.hpp"

namespace depowder::planner {

/// Values of progress_t.PHASE_* (0 for moves between parts and home).
enum class Phase : std::int8_t { kNone = 0, kVacuumBuried = 1, kVacuumTracked = 2, kAirBlast = 3, kDone = 4 };
const char* toString(Phase p);

enum class PlanStatus {
  kOk,                ///< waypoints to run
  kHold,              ///< no waypoints: hold position (missing / stale / bad input)
  kNoPath,            ///< the path generator or IK / collision left nothing
  kTransitionFailed,  ///< the nozzle cannot get to the path (OMPL / lift failed)
  kHome,              ///< waypoints to the home pose
};
const char* toString(PlanStatus s);

struct Plan {
  PlanStatus status = PlanStatus::kHold;
  std::string reason;  ///< why this plan, in words (goes into nozzle_plan_t.reason)
  std::string part;    ///< "" for home / hold without a part
  Phase phase = Phase::kNone;
  std::vector<Waypoint> waypoints;
  std::int64_t utime = 0;  ///< utime of the frame whose estimate caused this plan
  std::int64_t plan_id = 0;
  // Measurements.
  double planning_ms = 0;  ///< wall time to build it
  double path_ms = 0;      ///< of which the loop / raster geometry
  int path_waypoints = 0;  ///< waypoints of the part's own path (without transitions)
  LoopSource source = LoopSource::kContour;
  PathReport report;
  std::vector<TransitionResult> transitions;  ///< entry first, then between pieces
  bool hasWaypoints() const { return !waypoints.empty(); }
};

/// What a cycle on one part needs. The part's pose and state are those set in the world.
struct CycleRequest {
  std::size_t part = 0;
  Phase phase = Phase::kVacuumBuried;
  Cloud contour;             ///< powder contour (cell frame); empty: footprint loop
  std::string no_contour;    ///< why there is no contour to use (for the reason), if empty
  double powder_height = 0;  ///< m, cell z (progress h_pow); vacuum phases only
  robot::Joints q_now{};     ///< where the arm is
  bool try_direct = true;    ///< allow straight joint-space transitions (benchmarks force OMPL)
};

/// Builds one cycle. Never throws for bad geometry: a status and a reason instead.
Plan planCycle(const CollisionWorld& world, const CycleRequest& request, const PlannerConfig& config);

/// Tool-off move from q_now to the arm's home pose (lifting out of the powder first).
Plan planHome(const CollisionWorld& world, const robot::Joints& q_now, const PlannerConfig& config,
              const std::string& why);

}  // namespace depowder::planner
