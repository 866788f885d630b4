// The `robot` section of the cell YAML -> DriverConfig (+ the process's own options).
// Shared by depowder-driver and the simulator (which sets up its b-CAP emulator from the same
// section: port, joint limits, home joints, tool I/O variable names).
#pragma once

#include <string>

#include "depowder/node/cell.hpp"
#include "depowder/robot/driver.hpp"

namespace depowder::robot {

struct DriverNodeOptions {
  double state_rate_hz = 125;                        ///< ROBOT_STATE publishing rate
  double heartbeat_period_s = 0.5;                   ///< HEARTBEAT period
  std::string planner_process = "depowder-planner";  ///< heartbeat_t.process of the planner
  bool realtime = true;                              ///< try SCHED_FIFO for the slave loop thread (falls back silently)
};

struct RobotSection {
  DriverConfig driver;
  DriverNodeOptions node;
};

/// Reads cell.root.child("robot"); every key is optional (defaults of the structs) and checked
/// against its range; unknown keys are refused. Throws node::ConfigError naming file and key.
RobotSection readRobotSection(const node::CellConfig& cell);

}  // namespace depowder::robot
