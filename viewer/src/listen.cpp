#include "depowder/viewer/listen.hpp"

#include <poll.h>

#include <chrono>

#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/sim_truth_t.hpp"

namespace depowder::viewer {

void subscribe(node::Bus& bus, SceneModel& model, const Channels& channels) {
  SceneModel* m = &model;
  bus.subscribe<point_cloud_t>(channels.points,
                               [m](const point_cloud_t& msg, const std::string&) { m->onPoints(msg); });
  bus.subscribe<part_pose_t>(channels.part_pose,
                             [m](const part_pose_t& msg, const std::string&) { m->onPartPose(msg); });
  bus.subscribe<progress_t>(channels.progress, [m](const progress_t& msg, const std::string&) { m->onProgress(msg); });
  bus.subscribe<sim_truth_t>(channels.sim_truth,
                             [m](const sim_truth_t& msg, const std::string&) { m->onSimTruth(msg); });
  bus.subscribe<nozzle_plan_t>(channels.nozzle_plan,
                               [m](const nozzle_plan_t& msg, const std::string&) { m->onNozzlePlan(msg); });
  bus.subscribe<robot_state_t>(channels.robot_state,
                               [m](const robot_state_t& msg, const std::string&) { m->onRobotState(msg); });
}

int drain(node::Bus& bus, int wait_ms, int budget_ms) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  int handled = 0;
  // Poll the LCM descriptor rather than counting handled messages: a message on a
  // channel nobody here subscribes to (DEPTH_*, HEARTBEAT) must not end the drain.
  pollfd p{bus.fileno(), POLLIN, 0};
  if (poll(&p, 1, wait_ms) <= 0) return 0;
  do {
    handled += bus.spinOnce(0);
    p.revents = 0;
  } while (Clock::now() - start < std::chrono::milliseconds(budget_ms) && poll(&p, 1, 0) > 0);
  return handled;
}

}  // namespace depowder::viewer
