// Cell files from the user: loadCellFromString, then every reader a process runs on the cell at
// start (tracker, progress, planner, driver, camera proxy, and the tool the viewer and the
// self-filter draw). Anything that is not a valid cell is a ConfigError naming what was wrong,
// never a crash or another exception.
#include <optional>
#include <string>

#include "camera_options.hpp"
#include "depowder/node/cell.hpp"
#include "driver_config.hpp"
#include "planner_node.hpp"
#include "progress_node.hpp"
#include "tracker_node.hpp"

using namespace depowder;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::optional<node::CellConfig> loaded;
  try {
    loaded = node::loadCellFromString(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const node::ConfigError&) {
    return 0;
  }
  const node::CellConfig& cell = *loaded;
  // Each reader alone: one that refuses the cell does not keep the others from reading it.
  const auto read = [](auto&& reader) {
    try {
      reader();
    } catch (const node::ConfigError&) {
    }
  };
  read([&] { node::readTool(cell); });
  read([&] { tracker::readTrackerOptions(cell); });
  read([&] { progress::readProgressOptions(cell); });
  read([&] { planner::readPlannerOptions(cell); });
  read([&] { robot::readRobotSection(cell); });
  read([&] { perception::readCameraOptions(cell); });
  return 0;
}
