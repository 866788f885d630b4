// depowder-sim: the simulated cell. Steps the world at a fixed rate, publishes DEPTH_<CAM>
// per camera at its rate, SIM_TRUTH and HEARTBEAT. The library (depowder/sim) does the
// work; this file is configuration, the clock and the bus.
#include <chrono>
#include <cstring>
#include <iostream>
#include <stdexcept>
#include <string>
#include <thread>

#include "depowder/depth_image_t.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/robot/kinematics.hpp"
#include "depowder/sim_truth_t.hpp"
#include "driver_config.hpp"
#include "emulated_arm.hpp"
#include "setup.hpp"

using namespace depowder;
using namespace depowder::sim;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-sim: " << error << "\n";
  std::cerr << "usage: depowder-sim [--config FILE] [--scenario FILE] [--seed N] [--duration S] [--realtime|--fast]\n"
               "                    [--arm script|emulator] [--url URL] [--prefix P]\n"
               "  The simulated cell: publishes DEPTH_<CAM> (depth_image_t) per camera at its rate, SIM_TRUTH\n"
               "  (sim_truth_t) and HEARTBEAT.\n"
               "  --config FILE    cell YAML (default: $DEPOWDER_CELL or config/cell.yaml); --cell is the same\n"
               "  --scenario FILE  a full cell file used instead, or a file with only a `sim:` section that\n"
               "                   replaces the cell's (config/scenarios/)\n"
               "  --seed N         noise seed (overrides sim.seed)\n"
               "  --arm A          what moves the nozzle (overrides sim.arm): the scripted nozzle (sim.script), or\n"
               "                   the arm of the b-CAP controller emulator that depowder-driver commands\n"
               "  --duration S     stop after S simulated seconds (default: run until SIGINT/SIGTERM)\n"
               "  --realtime       pace simulated time to the wall clock; utime = wall clock (default)\n"
               "  --fast           as fast as possible; utime = simulated time (microseconds from 0)\n"
               "  --url URL        LCM URL (overrides lcm.url); --prefix P: channel prefix (overrides lcm.prefix)\n";
  return error.empty() ? 0 : 2;
}

depth_image_t toMsg(const DepthImage& img, std::int64_t utime) {
  depth_image_t m;
  m.utime = utime;
  m.frame = img.frame;
  m.camera = img.camera;
  m.width = img.width;
  m.height = img.height;
  m.fx = img.fx;
  m.fy = img.fy;
  m.cx = img.cx;
  m.cy = img.cy;
  m.min_range = static_cast<float>(img.min_range);
  m.max_range = static_cast<float>(img.max_range);
  m.T_cell_camera = node::toMsg(img.T_cell_camera);
  m.depth_unit = static_cast<float>(img.depth_unit);
  m.num_bytes = static_cast<std::int32_t>(img.depth.size() * 2);
  m.data.resize(m.num_bytes);
  for (std::size_t i = 0; i < img.depth.size(); ++i) {  // little-endian on every host
    m.data[2 * i] = static_cast<std::uint8_t>(img.depth[i] & 0xFF);
    m.data[2 * i + 1] = static_cast<std::uint8_t>(img.depth[i] >> 8);
  }
  return m;
}

sim_truth_t toMsg(const Truth& t, std::int64_t utime) {
  sim_truth_t m;
  m.utime = utime;
  for (const PartTruth& p : t.parts) {
    part_truth_t q;
    q.part = p.name;
    q.T_cell_part = node::toMsg(p.T_cell_part);
    q.eta = p.eta;
    q.nozzle_contact = p.nozzle_contact;
    q.speed = p.speed;
    m.parts.push_back(q);
  }
  m.num_parts = static_cast<std::int32_t>(m.parts.size());
  m.T_cell_nozzle = node::toMsg(t.T_cell_nozzle);
  m.tool = static_cast<std::int8_t>(t.tool);
  m.powder_removed_m3 = t.powder_removed_m3;
  m.contact_count = t.contact_count;
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  std::string config_path = node::defaultCellPath(), scenario_path, url, prefix, arm_choice;
  bool have_url = false, have_prefix = false, fast = false;
  long long seed = -1;
  double duration = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (a == "--fast" || a == "--realtime") {
      fast = a == "--fast";
      continue;
    }
    if (a != "--config" && a != "--cell" && a != "--arm" && a != "--scenario" && a != "--seed" && a != "--duration" &&
        a != "--url" && a != "--prefix")
      return usage("unknown option " + a);
    if (i + 1 >= argc) return usage("missing value after " + a);
    const std::string v = argv[++i];
    try {
      if (a == "--config" || a == "--cell") config_path = v;
      if (a == "--scenario") scenario_path = v;
      if (a == "--arm") {
        if (v != "script" && v != "emulator") return usage("--arm must be script or emulator");
        arm_choice = v;
      }
      if (a == "--url") url = v, have_url = true;
      if (a == "--prefix") prefix = v, have_prefix = true;
      std::size_t used = 0;
      if (a == "--seed" && ((seed = std::stoll(v, &used)) < 0 || seed > 0xFFFFFFFFll || used != v.size()))
        return usage("--seed must be an integer in [0, 4294967295]");
      if (a == "--duration" && (!((duration = std::stod(v, &used)) >= 0) || used != v.size()))
        return usage("--duration must be a number of seconds >= 0");
    } catch (const std::exception&) {
      return usage("bad value '" + v + "' for " + a);
    }
  }

  try {
    // 1. Configuration and the world.
    SimSetup setup = loadSimSetup(config_path, scenario_path);
    if (seed >= 0) setup.seed = static_cast<std::uint32_t>(seed);
    std::unique_ptr<World> world = makeWorld(setup);
    if (!arm_choice.empty()) setup.arm = arm_choice;
    if (const std::string why = faultsProblem(setup); !why.empty())
      throw std::runtime_error("--arm " + setup.arm + ": " + why);
    NozzleScript script(setup.script, setup.script_loop);
    ArmSource* arm = &script;
    std::unique_ptr<PushScript> push = makePushScript(setup, *world);  // sim.push: the nozzle pushes a part
    if (push) arm = push.get();
    // With `arm: emulator` the nozzle is the arm's: depowder-driver moves it over b-CAP.
    std::unique_ptr<BcapEmulator> emulator;
    std::unique_ptr<EmulatedArm> emulated;
    if (setup.arm == "emulator") {
      const robot::RobotSection robot_cfg = robot::readRobotSection(node::loadCell(setup.cell_file));
      const robot::SessionConfig& session = robot_cfg.driver.session;
      emulator =
          std::make_unique<BcapEmulator>(emulatorConfig(robot_cfg.driver.arm, session.client.port, setup.emulator_bind,
                                                        session.vacuum_variable, session.air_variable));
      std::string error;
      if (!emulator->start(&error))
        throw std::runtime_error("b-CAP controller emulator: " + error + " (sim.emulator_bind " + setup.emulator_bind +
                                 ", robot.controller.port " + std::to_string(session.client.port) + ")");
      emulated = std::make_unique<EmulatedArm>(*emulator, robot_cfg.driver.arm);
      world->setArmLinks(emulated->linkMeshes());
      arm = emulated.get();
      std::cout << "depowder-sim: b-CAP controller emulator on " << setup.emulator_bind << ":" << emulator->port()
                << (fast ? " (the arm moves in wall-clock time even with --fast)" : "") << std::endl;
    }

    // 2. Bus and heartbeat.
    node::installShutdownHandlers();
    node::Bus bus(have_url ? url : setup.lcm.url, have_prefix ? prefix : setup.lcm.prefix);
    node::Heartbeat heartbeat(bus, "depowder-sim");
    heartbeat.setStat("cell_model",
                      node::cellModelId(node::loadCell(setup.cell_file)));  // depowder-status compares hosts
    heartbeat.setState(heartbeat_t::RUNNING);
    heartbeat.publish();
    std::cout << "depowder-sim: " << world->partCount() << " parts, " << world->cameras().size() << " cameras, "
              << world->powder().nx() << "x" << world->powder().ny() << " powder cells, seed " << setup.seed << ", "
              << (fast ? "fast" : "real time") << ", cell " << setup.cell_file << std::endl;

    // 3. Main loop: one fixed step at a time; frames and truth fall on multiples of their periods.
    const double dt = 1.0 / setup.step_hz;
    const std::int64_t start_utime = fast ? 0 : node::nowUtime();
    const auto start_wall = std::chrono::steady_clock::now();
    auto utimeAt = [&](double t) { return start_utime + static_cast<std::int64_t>(std::llround(t * 1e6)); };
    std::vector<std::int64_t> frames_due(world->cameras().size(), 1);  // frame k at k / rate (from one period)
    std::int64_t truth_due = 1;
    double render_ms = 0, step_ms = 0, lag_s = 0;
    std::int64_t frames = 0;
    std::int64_t refusals_logged = 0;  // the emulated controller's refusals printed so far
    std::vector<bool> fault_done(setup.faults.size(), false), fault_over(setup.faults.size(), false);
    auto silenced = [&](const std::string& camera, double t) {
      for (const SimSetup::Fault& f : setup.faults)
        if (f.silence_camera == camera && t >= f.at && t < f.at + f.duration) return true;
      return false;
    };
    for (std::int64_t k = 1; !node::shutdownRequested(); ++k) {
      const double t = k * dt;
      if (duration > 0 && t > duration + 1e-9) break;

      // 3a. The arm: one call per step (scripted nozzle now, the b-CAP emulator later).
      world->setArm(arm->update(t));

      // 3a'. Injected faults (sim.faults): a pulled controller cable; silenced cameras below. A
      // silenced camera's end is reported in the same form: a sim catching up after a stall ends
      // it earlier in wall time than its start + duration (test/faults.sh reads both).
      auto announce = [&](const char* event, const std::string& what) {
        std::cout << "depowder-sim: " << event << " at t = " << t << " s (utime " << utimeAt(t) << ", wall utime "
                  << node::nowUtime() << "): " << what << std::endl;
      };
      for (std::size_t i = 0; i < setup.faults.size(); ++i) {
        const SimSetup::Fault& f = setup.faults[i];
        if (!fault_done[i] && t >= f.at) {
          fault_done[i] = true;
          if (f.drop_controller && emulator) emulator->dropConnections();
          announce("fault", f.drop_controller
                                ? std::string("controller connections dropped")
                                : "camera " + f.silence_camera + " silent for " + std::to_string(f.duration) + " s");
        }
        if (!fault_over[i] && !f.silence_camera.empty() && t >= f.at + f.duration) {
          fault_over[i] = true;
          announce("fault over", "camera " + f.silence_camera + " publishes again");
        }
      }

      // 3b. Physics of the powder and contacts.
      const auto s0 = std::chrono::steady_clock::now();
      world->step(dt);
      step_ms = 0.95 * step_ms +
                0.05 * std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count();

      // 3c. Pacing: in real time, publish no earlier than the wall clock reaches t.
      if (!fast) {
        const auto due = start_wall + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                          std::chrono::duration<double>(t));
        const auto now = std::chrono::steady_clock::now();
        lag_s = std::chrono::duration<double>(now - due).count();
        if (now < due) std::this_thread::sleep_until(due);
      }

      // Every message of this step carries one utime: in real time the wall clock now (a real
      // camera's capture time: if the sim falls behind, its frames are not stamped in the past,
      // where the driver would find every plan stale), with --fast the simulated time.
      const std::int64_t step_utime = fast ? utimeAt(t) : node::nowUtime();

      // 3d. Cameras whose next frame time has come.
      for (std::size_t c = 0; c < frames_due.size(); ++c) {
        const double rate = world->cameras()[c].rate_hz;
        if (t + 1e-9 < frames_due[c] / rate) continue;
        while (frames_due[c] / rate <= t + 1e-9) ++frames_due[c];
        if (silenced(world->cameras()[c].name, t)) continue;
        const auto r0 = std::chrono::steady_clock::now();
        const DepthImage img = world->render(c);
        render_ms = 0.95 * render_ms +
                    0.05 * std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - r0).count();
        bus.publish("DEPTH_" + img.camera, toMsg(img, step_utime));
        ++frames;
      }

      // 3e. Ground truth (evaluation only).
      if (t + 1e-9 >= truth_due / setup.truth_hz) {
        while (truth_due / setup.truth_hz <= t + 1e-9) ++truth_due;
        bus.publish("SIM_TRUTH", toMsg(world->truth(), step_utime));
      }

      // 3f. Heartbeat.
      for (const std::string& e : bus.takeErrors()) std::cerr << "depowder-sim: " << e << std::endl;
      heartbeat.setStat("sim_time_s", t);
      heartbeat.setStat("frames", static_cast<double>(frames));
      heartbeat.setStat("render_ms", render_ms);
      heartbeat.setStat("step_ms", step_ms);
      heartbeat.setStat("lag_s", lag_s);
      heartbeat.setStat("powder_removed_cm3", world->powderRemoved() * 1e6);
      if (emulator) {  // what the emulated controller refused (a real RC8 logs these as errors)
        const EmulatorStats es = emulator->stats();
        const std::int64_t refusals = es.late_errors + es.limit_errors + es.speed_errors;
        if (refusals > refusals_logged) {  // each one stops the arm: rare, and worth a line
          std::cerr << "depowder-sim: controller error: " << es.last_refusal;
          if (refusals > refusals_logged + 1) std::cerr << " (and " << refusals - refusals_logged - 1 << " more)";
          std::cerr << std::endl;
          refusals_logged = refusals;
        }
        heartbeat.setStat("controller_late_errors", static_cast<double>(es.late_errors));
        heartbeat.setStat("controller_limit_errors", static_cast<double>(es.limit_errors));
        heartbeat.setStat("controller_speed_errors", static_cast<double>(es.speed_errors));
      }
      heartbeat.setState(!fast && lag_s > 0.25 ? heartbeat_t::DEGRADED : heartbeat_t::RUNNING,
                         !fast && lag_s > 0.25 ? "behind real time by " + std::to_string(lag_s) + " s" : "");
      heartbeat.tick();
    }
    heartbeat.setState(heartbeat_t::STOPPING);
    heartbeat.publish();
    std::cout << "depowder-sim: stopped at t = " << world->time() << " s, " << frames << " frames" << std::endl;
  } catch (const std::exception& e) {
    std::cerr << "depowder-sim: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
