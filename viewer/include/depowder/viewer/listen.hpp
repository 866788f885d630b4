// Wires a SceneModel to the cell's channels. Handlers only overwrite the newest
// message of each kind, so a slow renderer drops frames here, never in the cell.
#pragma once

#include <string>

#include "depowder/node/bus.hpp"
#include "depowder/viewer/scene.hpp"

namespace depowder::viewer {

struct Channels {
  std::string points = "POINTS";
  std::string part_pose = "PART_POSE";
  std::string progress = "PROGRESS";
  std::string sim_truth = "SIM_TRUTH";
  std::string nozzle_plan = "NOZZLE_PLAN";
  std::string robot_state = "ROBOT_STATE";
};

/// Subscribes `model` to every channel (the bus adds its prefix). `model` must outlive `bus`.
void subscribe(node::Bus& bus, SceneModel& model, const Channels& channels = {});

/// Handles whatever is waiting on the bus, for at most `budget_ms`, after waiting up to
/// `wait_ms` for the first message. Returns the number handled by subscriptions here.
int drain(node::Bus& bus, int wait_ms, int budget_ms = 50);

}  // namespace depowder::viewer
