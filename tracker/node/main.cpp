// depowder-tracker: POINTS -> PART_POSE for every part of the cell (CU-ICP, paper Alg. 1, or a
// baseline), with HEARTBEAT. The logic is in tracker_node.hpp; this file is the bus.
#include <chrono>
#include <iostream>
#include <map>
#include <optional>
#include <string>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/point_cloud_t.hpp"
#include "tracker_node.hpp"

using namespace depowder;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-tracker: " << error << "\n";
  (error.empty() ? std::cout : std::cerr)
      << "usage: depowder-tracker [--config FILE] [--method cu|continuous|vanilla] [--state FILE] [--url URL]\n"
         "                        [--prefix P]\n"
         "  Subscribes POINTS; publishes PART_POSE (part_pose_t) for every part of the cell with each\n"
         "  frame's utime, and HEARTBEAT with per-frame timing. If it falls behind, it tracks the newest\n"
         "  frame and counts the skipped ones as dropped.\n"
         "  --config FILE  cell YAML (default: $DEPOWDER_CELL or config/cell.yaml); section `tracker`\n"
         "                 (--cell FILE is the same)\n"
         "  --method M     cu (CU-ICP, default), continuous or vanilla: overrides tracker.method\n"
         "  --state FILE   keep the last poses in FILE; a restart resumes from them (overrides\n"
         "                 tracker.state_file)\n"
         "  --url URL      LCM URL (overrides lcm.url)\n"
         "  --prefix P     channel prefix (overrides lcm.prefix)\n";
  return error.empty() ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cell_path = node::defaultCellPath(), url, prefix, method, state_file;
  bool have_url = false, have_prefix = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (a != "--config" && a != "--cell" && a != "--method" && a != "--state" && a != "--url" && a != "--prefix")
      return usage("unknown option " + a);
    if (i + 1 >= argc) return usage("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--config" || a == "--cell") cell_path = v;
    if (a == "--method") method = v;
    if (a == "--state") state_file = v;
    if (a == "--url") url = v, have_url = true;
    if (a == "--prefix") prefix = v, have_prefix = true;
  }
  if (!method.empty() && !tracker::methodFromString(method))
    return usage("--method must be cu, continuous or vanilla, not '" + method + "'");

  try {
    // 1. Configuration and the parts' meshes: an error here is a configuration error.
    const node::CellConfig cell = node::loadCell(cell_path);
    tracker::TrackerNodeOptions options = tracker::readTrackerOptions(cell);
    if (!method.empty()) options.tracker.method = *tracker::methodFromString(method);
    if (!state_file.empty()) options.state_file = state_file;
    // A restart resumes from the last published poses; a broken state file is reported and ignored.
    std::map<std::string, tracker::SavedPose> resume;
    if (!options.state_file.empty()) {
      try {
        resume = tracker::loadTrackerState(options.state_file);
      } catch (const std::exception& e) {
        std::cerr << "depowder-tracker: ignoring the state file: " << e.what() << std::endl;
      }
      for (const auto& [name, saved] : resume)
        std::cout << "depowder-tracker: " << name << " resumes from its pose of utime " << saved.utime << " ("
                  << options.state_file << ")" << std::endl;
    }
    tracker::TrackerNode logic(cell, options, resume);
    auto last_save = std::chrono::steady_clock::now();
    std::string state_error;  // the state file's last write error

    // 2. Bus and heartbeat. The handler only keeps the newest frame; the loop tracks it.
    node::installShutdownHandlers();
    node::Bus bus(have_url ? url : cell.lcm.url, have_prefix ? prefix : cell.lcm.prefix);
    node::Heartbeat heartbeat(bus, "depowder-tracker", options.heartbeat_period);
    heartbeat.setStat("cell_model", node::cellModelId(cell));  // depowder-status compares hosts
    std::optional<point_cloud_t> pending;
    std::int64_t pending_arrival = 0;  // node::steadyUtime when it arrived (the far-ahead rule)
    std::int64_t skipped = 0;
    std::int64_t bad_frames = 0;  // refused and invalid, when input_problem was taken
    std::string input_problem;
    std::chrono::steady_clock::time_point input_problem_at{};
    bus.subscribe<point_cloud_t>("POINTS", [&](const point_cloud_t& msg, const std::string&) {
      if (pending) {
        ++skipped;  // a newer frame arrived before this one was tracked: drop the stale one
        heartbeat.addDropped();
      }
      pending = msg;
      pending_arrival = node::steadyUtime();
    });
    heartbeat.setState(heartbeat_t::RUNNING);
    heartbeat.publish();
    std::cout << "depowder-tracker: " << logic.partNames().size() << " parts, method " << logic.method() << ", "
              << logic.trackers().threads() << " threads, cell " << cell.file << std::endl;

    // 3. Main loop: take every waiting message, track the newest frame, publish.
    while (!node::shutdownRequested()) {
      bus.spinOnce(pending ? 0 : 20);
      while (bus.spinOnce(0) > 0) {
      }
      if (pending) {
        const point_cloud_t frame = std::move(*pending);
        pending.reset();
        for (const part_pose_t& m : logic.onPoints(frame, pending_arrival)) bus.publish("PART_POSE", m);
      }
      if (!options.state_file.empty() && !logic.lastPoses().empty() &&
          std::chrono::steady_clock::now() - last_save > std::chrono::duration<double>(options.state_period)) {
        last_save = std::chrono::steady_clock::now();
        const std::string error = tracker::saveTrackerState(options.state_file, logic.lastPoses());
        if (!error.empty() && state_error.empty()) std::cerr << "depowder-tracker: state file: " << error << std::endl;
        state_error = error;
      }
      for (const std::string& e : bus.takeErrors()) std::cerr << "depowder-tracker: " << e << std::endl;

      const auto& s = logic.stats();
      heartbeat.setStat("frames_in", static_cast<double>(s.frames));
      heartbeat.setStat("frames_invalid", static_cast<double>(s.invalid_frames));
      heartbeat.setStat("frames_refused", static_cast<double>(s.refused_frames));
      heartbeat.setStat("clock_restarts", static_cast<double>(s.clock_restarts));
      heartbeat.setStat("frames_skipped", static_cast<double>(skipped));
      heartbeat.setStat("gap_periods_max", s.max_gap_periods);
      heartbeat.setStat("frame_ms_p50", s.frame_ms_p50);
      heartbeat.setStat("frame_ms_p90", s.frame_ms_p90);
      heartbeat.setStat("frame_ms_max", s.frame_ms_max);
      // A frame refused or broken is shown for 2 s, not only until the next frame tracks.
      const auto now = std::chrono::steady_clock::now();
      if (s.refused_frames + s.invalid_frames > bad_frames) {
        bad_frames = s.refused_frames + s.invalid_frames;
        input_problem = s.last_problem;
        input_problem_at = now;
      }
      std::string problem = s.last_problem;
      if (now - input_problem_at < std::chrono::seconds(2) && problem != input_problem)
        problem += (problem.empty() ? "" : "; ") + input_problem;
      if (!problem.empty())
        heartbeat.setState(heartbeat_t::DEGRADED, problem);
      else if (!state_error.empty())
        heartbeat.setState(heartbeat_t::DEGRADED, "state file: " + state_error);
      else
        heartbeat.setState(heartbeat_t::RUNNING);
      heartbeat.tick();
    }
    heartbeat.setState(heartbeat_t::STOPPING);
    heartbeat.publish();
  } catch (const std::exception& e) {
    std::cerr << "depowder-tracker: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
