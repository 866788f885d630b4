// An evaluation cell from a cell file: what the processes of the cell would run with.
#include <string>

#include "camera_options.hpp"
#include "depowder/eval/scene.hpp"
#include "depowder/node/cell.hpp"
#include "setup.hpp"
#include "tracker_node.hpp"

namespace depowder::eval {

EvalCell loadEvalCell(const std::string& path) {
  const node::CellConfig cell = node::loadCell(path.empty() ? node::defaultCellPath() : path);
  // depowder-sim's box, cameras and sim section (powder, tools, physics, camera noise).
  const sim::SimSetup setup = sim::simSetupOf(cell);
  EvalCell out;
  out.box = setup.box;
  out.cameras = setup.cameras;
  if (out.cameras.empty()) throw node::ConfigError(setup.cell_file + ": no cameras");
  out.sim = setup.config;
  // Rigid-body physics as each experiment needs it: off in static and speed (the part held still or
  // moved by the actuator), on in moving (runMoving turns it on).
  out.sim.physics.enabled = false;
  out.step_hz = setup.step_hz;
  out.fps = out.cameras.front().rate_hz;
  // depowder-camera's perception section (crop, voxel leaf, outlier filter, merger).
  out.perception = perception::readCameraOptions(cell).perception;
  // depowder-tracker's tracker section (with the progress section's Eq. 2 settings), but ICP at
  // every visibility (baseTrackerConfig) and the cameras as viewpoints (evalTrackerConfig).
  out.tracker = tracker::readTrackerOptions(cell).tracker;
  out.tracker.eta1 = baseTrackerConfig().eta1;
  out.tracker.viewpoints.clear();
  return out;
}

}  // namespace depowder::eval
