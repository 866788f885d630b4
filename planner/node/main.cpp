// depowder-planner: PART_POSE + PROGRESS + ROBOT_STATE -> NOZZLE_PLAN (paper Sec. III-B: contour
// paths through the three phases, FCL-checked, OMPL transitions, one part per cycle), with a
// heartbeat. The logic is in planner_node.hpp and the library; this file is the bus.
#include <chrono>
#include <iomanip>
#include <iostream>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/args.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "planner_node.hpp"

using namespace depowder;

namespace {

const char* const kUsage =
    "usage: depowder-planner [--cell FILE] [--url URL] [--prefix P]\n"
    "  Subscribes PART_POSE, PROGRESS and ROBOT_STATE; publishes NOZZLE_PLAN (nozzle_plan_t, stamped\n"
    "  with the utime of the frame that caused it) and HEARTBEAT.\n"
    "  --cell FILE   cell YAML (default: $DEPOWDER_CELL or config/cell.yaml); sections `planner`, `robot`\n"
    "  --url URL     LCM URL (overrides lcm.url)\n"
    "  --prefix P    channel prefix (overrides lcm.prefix)\n";

}  // namespace

int main(int argc, char** argv) {
  int exit_code = 0;
  const auto args = node::parseNodeArgs(argc, argv, "depowder-planner", kUsage, &exit_code);
  if (!args) return exit_code;

  try {
    // 1. Configuration, part meshes and their BVHs.
    const node::CellConfig cell = node::loadCell(args->cell);
    const planner::PlannerNodeOptions options = planner::readPlannerOptions(cell);
    planner::PlannerNode logic(cell, options);

    // 2. Bus, heartbeat, subscriptions. Handlers only hand inputs over; the loop plans.
    node::installShutdownHandlers();
    node::Bus bus(args->url.value_or(cell.lcm.url), args->prefix.value_or(cell.lcm.prefix));
    node::Heartbeat heartbeat(bus, "depowder-planner", options.heartbeat_period);
    heartbeat.setStat("cell_model", node::cellModelId(cell));  // depowder-status compares hosts
    heartbeat.setStat("arm_model", options.arm_model);         // the driver moves only an arm it shares
    // A rejection, or a note on an input taken (the clock went back, contour points left out):
    // printed once per distinct reason, rejections counted always.
    std::string last_said;
    auto report = [&](const planner::InputResult& r) {
      if (!r.ok()) heartbeat.addDropped();
      if (r.reason.empty() || r.reason == last_said) return;
      std::cerr << "depowder-planner: " << (r.ok() ? "" : "rejected: ") << r.reason << std::endl;
      last_said = r.reason;
    };
    bus.subscribe<part_pose_t>(
        "PART_POSE", [&](const part_pose_t& m, const std::string&) { report(logic.onPose(m, node::steadyUtime())); });
    bus.subscribe<progress_t>(
        "PROGRESS", [&](const progress_t& m, const std::string&) { report(logic.onProgress(m, node::steadyUtime())); });
    // A driver that has just started (or come back) refuses plans until it has heard this
    // planner's heartbeat: its first ROBOT_STATE after a silence gets one at once, ahead of the
    // plan it leads to, rather than at the next tick.
    std::chrono::steady_clock::time_point last_robot_state{};
    bus.subscribe<robot_state_t>("ROBOT_STATE", [&](const robot_state_t& m, const std::string&) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_robot_state > std::chrono::seconds(1)) heartbeat.publish();
      last_robot_state = now;
      report(logic.onRobot(m));
    });
    heartbeat.setState(heartbeat_t::RUNNING);
    heartbeat.publish();
    std::cout << "depowder-planner: " << cell.parts.size() << " parts, cell " << cell.file << std::endl;

    // 3. Main loop: take the messages, decide, publish a plan when there is a new one.
    while (!node::shutdownRequested()) {
      bus.spinOnce(10);
      if (std::optional<nozzle_plan_t> plan = logic.step()) {
        bus.publish("NOZZLE_PLAN", *plan);
        if (plan->reason.rfind("refresh: ", 0) != 0)
          std::cout << "depowder-planner: plan " << plan->plan_id << " (" << plan->part << ", " << plan->num_waypoints
                    << " waypoints, " << std::fixed << std::setprecision(1) << logic.stats().last_planning_ms
                    << " ms): " << plan->reason << std::endl;
      }
      for (const std::string& e : bus.takeErrors()) std::cerr << "depowder-planner: " << e << std::endl;

      const auto& s = logic.stats();
      heartbeat.setStat("plans", static_cast<double>(s.plans));
      heartbeat.setStat("holds", static_cast<double>(s.holds));
      heartbeat.setStat("refreshes", static_cast<double>(s.refreshes));
      heartbeat.setStat("rejected", static_cast<double>(s.rejected));
      heartbeat.setStat("clock_restarts", static_cast<double>(logic.planner().clockRestarts()));
      heartbeat.setStat("planning_ms", s.last_planning_ms);
      heartbeat.setStat("path_ms", s.last_path_ms);
      for (const planner::PartReport& p : logic.planner().parts()) {
        heartbeat.setStat("phase_" + p.name, static_cast<double>(p.phase));
        heartbeat.setStat("cycles_" + p.name, p.cycles);
        heartbeat.setStat("lost_" + p.name, p.lost ? 1 : 0);
      }
      if (s.holding)
        heartbeat.setState(heartbeat_t::DEGRADED, s.last_reason);
      else
        heartbeat.setState(heartbeat_t::RUNNING);
      heartbeat.tick();
    }
    heartbeat.setState(heartbeat_t::STOPPING);
    heartbeat.publish();
  } catch (const std::exception& e) {
    std::cerr << "depowder-planner: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
