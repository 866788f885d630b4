// The processes' logic behind the bus, on messages that decode but say anything: a sequence
// of POINTS, PART_POSE, PROGRESS, ROBOT_STATE and NOZZLE_PLAN messages goes to the tracker,
// progress and planner nodes of the static cube cell (config/scenarios/static.yaml), built anew
// for each input so that a failure replays alone. Nothing may crash; what a node rejects it says.
// Input: records of [kind byte][length, 2 bytes little-endian][the LCM message].
#include <algorithm>
#include <cstdlib>

#include "depowder/node/convert.hpp"
#include "fuzz.hpp"
#include "planner_node.hpp"
#include "progress_node.hpp"
#include "tracker_node.hpp"

using namespace depowder;
using fuzz::decoded;

namespace {

struct Cell {
  node::CellConfig cell = node::loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/scenarios/static.yaml");
  tracker::TrackerNodeOptions tracker = tracker::readTrackerOptions(cell);
  progress::ProgressNodeOptions progress = progress::readProgressOptions(cell);
  planner::PlannerNodeOptions planner = planner::readPlannerOptions(cell);
  Cell() { tracker.threads = 1; }  // one thread: the same input runs the same way
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Cell c;
  tracker::TrackerNode tracker(c.cell, c.tracker);
  progress::ProgressNode progress(c.cell, c.progress);
  planner::PlannerNode planner(c.cell, c.planner);
  std::int64_t now_us = 1'000'000;
  fuzz::forEachRecord(data, size, 5, [&](int kind, const std::uint8_t* msg, std::size_t n) {
    now_us += 33'000;
    if (kind == 0) {
      point_cloud_t m;
      if (!decoded(m, msg, n)) return;
      for (const part_pose_t& pose : tracker.onPoints(m, now_us)) {
        progress.onPose(pose);
        planner.onPose(pose, now_us);
      }
      if (std::optional<Cloud> cloud = node::decodeCloud(m)) progress.onPoints(m.utime, std::move(*cloud), now_us);
    } else if (kind == 1) {
      part_pose_t m;
      if (decoded(m, msg, n)) progress.onPose(m), planner.onPose(m, now_us);
    } else if (kind == 2) {
      progress_t m;
      if (decoded(m, msg, n)) planner.onProgress(m, now_us);
    } else if (kind == 3) {
      robot_state_t m;
      if (decoded(m, msg, n)) planner.onRobot(m);
    } else {
      nozzle_plan_t m;
      if (decoded(m, msg, n)) progress.onPlan(m);
    }
    for (const progress_t& p : progress.poll(now_us)) planner.onProgress(p, now_us);
    planner.step();
  });
  return 0;
}
