// depowder-planner's logic without the bus: options from the cell YAML, conversion of the
// LCM messages to the library's inputs (and of plans back), around a CellPlanner.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "depowder/node/cell.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/planner/cell_planner.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"

namespace depowder::planner {

struct PlannerNodeOptions {
  PlannerConfig planner;
  robot::ArmConfig arm;           ///< from the `robot` section (the driver's reader)
  double arm_model = 0;           ///< robot::armModelId of that arm and the workspace, for the driver
  double heartbeat_period = 0.5;  ///< s
};

/// Reads the `planner` section (keys mirror PlannerConfig: nozzle, vacuum, blast, collision,
/// transition, replan; plus heartbeat_period) and the arm and workspace from the `robot`
/// section. Unknown keys and out-of-range values throw node::ConfigError naming file and key.
PlannerNodeOptions readPlannerOptions(const node::CellConfig& cell);

/// Converts a plan to the wire (waypoint q, tool, speed; pose validated by the planner).
nozzle_plan_t toMsg(const Plan& plan);

class PlannerNode {
 public:
  /// Loads every part's mesh (throws MeshError naming the file).
  PlannerNode(const node::CellConfig& cell, const PlannerNodeOptions& options);

  /// Each returns the input's status; a rejected message changes nothing. `arrival`: when it
  /// arrived, us on a clock that only moves forward (CellPlanner::onPose).
  InputResult onPose(const part_pose_t& msg, std::int64_t arrival);
  InputResult onProgress(const progress_t& msg, std::int64_t arrival);
  InputResult onRobot(const robot_state_t& msg);
  /// A plan to publish, if there is one now.
  std::optional<nozzle_plan_t> step();

  struct Stats {
    std::int64_t plans = 0;       ///< NOZZLE_PLANs returned
    std::int64_t holds = 0;       ///< of them without waypoints
    std::int64_t refreshes = 0;   ///< of them re-sent running plans
    std::int64_t rejected = 0;    ///< input messages rejected
    double last_planning_ms = 0;  ///< wall time of the last new plan
    double last_path_ms = 0;      ///< of which the path geometry
    std::string last_reason;      ///< of the last plan
    std::string last_rejection;   ///< why the last rejected input was rejected
    bool holding = false;         ///< the last plan was a hold
  };
  const Stats& stats() const { return stats_; }
  const CellPlanner& planner() const { return planner_; }

 private:
  InputResult count(InputResult r);
  CellPlanner planner_;
  Stats stats_;
};

}  // namespace depowder::planner
