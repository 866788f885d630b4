// depowder-progress: POINTS + PART_POSE (+ NOZZLE_PLAN for the air-blast pass) -> PROGRESS per part
// (paper Sec. IV-C), with a heartbeat. The logic is in progress_node.hpp; this file is the bus.
#include <iostream>
#include <map>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/args.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/point_cloud_t.hpp"
#include "progress_node.hpp"

using namespace depowder;

namespace {

const char* const kUsage =
    "usage: depowder-progress [--cell FILE] [--url URL] [--prefix P]\n"
    "  Subscribes POINTS, PART_POSE and NOZZLE_PLAN; publishes PROGRESS (progress_t) for every part\n"
    "  of the cell with each POINTS frame's utime, and HEARTBEAT.\n"
    "  --cell FILE   cell YAML (default: $DEPOWDER_CELL or config/cell.yaml); section `progress`\n"
    "  --url URL     LCM URL (overrides lcm.url)\n"
    "  --prefix P    channel prefix (overrides lcm.prefix)\n";

}  // namespace

int main(int argc, char** argv) {
  int exit_code = 0;
  const auto args = node::parseNodeArgs(argc, argv, "depowder-progress", kUsage, &exit_code);
  if (!args) return exit_code;

  try {
    // 1. Configuration and the parts' CAD samples.
    const node::CellConfig cell = node::loadCell(args->cell);
    const progress::ProgressNodeOptions options = progress::readProgressOptions(cell);
    progress::ProgressNode logic(cell, options);

    // 2. Bus, heartbeat, subscriptions. Handlers only queue work; the loop publishes.
    node::installShutdownHandlers();
    node::Bus bus(args->url.value_or(cell.lcm.url), args->prefix.value_or(cell.lcm.prefix));
    node::Heartbeat heartbeat(bus, "depowder-progress", options.heartbeat_period);
    heartbeat.setStat("cell_model", node::cellModelId(cell));  // depowder-status compares hosts
    std::vector<progress_t> out;
    auto append = [&out](std::vector<progress_t> more) {
      for (auto& m : more) out.push_back(std::move(m));
    };
    // An input not used (a bad POINTS, a PART_POSE the node refused) is said in the heartbeat for
    // 2 s: the loop passes far more often than the heartbeat goes out.
    std::string input_problem;
    std::int64_t input_problem_us = 0, input_problems_seen = 0;
    auto noteProblem = [&](std::string why) {
      input_problem = std::move(why);
      input_problem_us = node::steadyUtime();
    };
    bus.subscribe<point_cloud_t>("POINTS", [&](const point_cloud_t& msg, const std::string&) {
      std::string why;
      std::optional<Cloud> cloud = node::decodeCloud(msg, &why);
      if (!cloud) {
        heartbeat.addDropped();
        noteProblem("bad POINTS frame: " + why);
        return;
      }
      const std::int64_t duplicates = logic.stats().duplicate_frames;
      append(logic.onPoints(msg.utime, std::move(*cloud), node::steadyUtime()));
      heartbeat.addDropped(logic.stats().duplicate_frames - duplicates);  // a frame received twice
    });
    bus.subscribe<part_pose_t>("PART_POSE",
                               [&](const part_pose_t& msg, const std::string&) { append(logic.onPose(msg)); });
    bus.subscribe<nozzle_plan_t>("NOZZLE_PLAN",
                                 [&](const nozzle_plan_t& msg, const std::string&) { logic.onPlan(msg); });
    heartbeat.setState(heartbeat_t::RUNNING);
    heartbeat.publish();
    std::cout << "depowder-progress: " << logic.partNames().size() << " parts, cell " << cell.file << std::endl;

    // 3. Main loop: handle messages, release frames that waited for their poses, publish.
    std::map<std::string, std::string> problems;  // per part, from its last message
    while (!node::shutdownRequested()) {
      bus.spinOnce(10);
      append(logic.poll(node::steadyUtime()));
      for (const progress_t& m : out) {
        bus.publish("PROGRESS", m);
        if (m.status == progress_t::OK)
          problems.erase(m.part);
        else
          problems[m.part] = m.status_reason;
        heartbeat.setStat("eta_" + m.part, m.eta);
        heartbeat.setStat("phase_" + m.part, m.phase);
      }
      out.clear();
      for (const std::string& e : bus.takeErrors()) std::cerr << "depowder-progress: " << e << std::endl;

      const auto& s = logic.stats();
      heartbeat.setStat("frames_in", static_cast<double>(s.frames));
      heartbeat.setStat("estimates", static_cast<double>(s.estimates));
      heartbeat.setStat("no_pose", static_cast<double>(s.no_pose));
      heartbeat.setStat("invalid_poses", static_cast<double>(s.invalid_poses));
      heartbeat.setStat("duplicate_frames", static_cast<double>(s.duplicate_frames));
      heartbeat.setStat("compute_ms", s.last_compute_ms);
      if (s.input_problems != input_problems_seen) {
        input_problems_seen = s.input_problems;
        noteProblem(s.last_problem);
      }
      const bool problem = !input_problem.empty() && node::steadyUtime() - input_problem_us < 2'000'000;
      if (!problems.empty())
        heartbeat.setState(heartbeat_t::DEGRADED, problems.begin()->first + ": " + problems.begin()->second);
      else if (problem)
        heartbeat.setState(heartbeat_t::DEGRADED, input_problem);
      else
        heartbeat.setState(heartbeat_t::RUNNING);
      heartbeat.tick();
    }
    heartbeat.setState(heartbeat_t::STOPPING);
    heartbeat.publish();
  } catch (const std::exception& e) {
    std::cerr << "depowder-progress: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
