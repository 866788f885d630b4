// depowder-driver: NOZZLE_PLAN / ESTOP / HEARTBEAT in, ROBOT_STATE (125 Hz) and HEARTBEAT out;
// the DENSO RC8 (or the simulator's emulator) over b-CAP. The logic is the depowder_robot
// library's Driver; this file is the bus and the threads: the 8 ms slave loop runs in its own
// thread, LCM and publishing in this one.
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <thread>

#include "depowder/estop_t.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "driver_config.hpp"
#include "plan_msg.hpp"

using namespace depowder;

namespace {

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-driver: " << error << "\n";
  std::cerr << "usage: depowder-driver [--cell FILE] [--url URL] [--prefix P] [--host H] [--port N]\n"
               "  Subscribes NOZZLE_PLAN, ESTOP and HEARTBEAT (the planner's); drives the arm over b-CAP\n"
               "  in slave mode; publishes ROBOT_STATE at robot.state_rate and HEARTBEAT.\n"
               "  --cell FILE   cell YAML (default: $DEPOWDER_CELL or config/cell.yaml); section `robot`\n"
               "  --url URL     LCM URL (overrides lcm.url)\n"
               "  --prefix P    channel prefix (overrides lcm.prefix)\n"
               "  --host H      controller address (overrides robot.controller.host)\n"
               "  --port N      controller port (overrides robot.controller.port)\n";
  return error.empty() ? 0 : 2;
}

robot_state_t toMsg(const robot::DriverStatus& s, std::int64_t utime) {
  robot_state_t m;
  m.utime = utime;
  m.mode = static_cast<std::int8_t>(s.mode);
  m.mode_reason = s.reason;
  m.measured = s.measured;
  for (int i = 0; i < 6; ++i) {
    m.q[i] = s.q[i];
    m.qd[i] = s.qd[i];
  }
  m.T_cell_nozzle = node::toMsg(s.T_cell_nozzle);
  m.tool = static_cast<std::int8_t>(s.tool);
  m.plan_id = s.plan_id;
  m.waypoint_index = s.waypoint_index;
  m.plan_utime = s.plan_utime;
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cell_path = node::defaultCellPath(), url, prefix, host;
  int port = 0;
  bool have_url = false, have_prefix = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage();
    if (a != "--cell" && a != "--url" && a != "--prefix" && a != "--host" && a != "--port")
      return usage("unknown option " + a);
    if (i + 1 >= argc) return usage("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--cell") cell_path = v;
    if (a == "--url") url = v, have_url = true;
    if (a == "--prefix") prefix = v, have_prefix = true;
    if (a == "--host") host = v;
    if (a == "--port") {
      char* end = nullptr;
      const long p = std::strtol(v.c_str(), &end, 10);
      if (*end != '\0' || p < 1 || p > 65535) return usage("--port must be 1..65535");
      port = static_cast<int>(p);
    }
  }

  try {
    // 1. Configuration.
    const node::CellConfig cell = node::loadCell(cell_path);
    robot::RobotSection section = robot::readRobotSection(cell);
    if (!host.empty()) section.driver.session.client.host = host;
    if (port != 0) section.driver.session.client.port = port;
    const robot::DriverNodeOptions& opt = section.node;
    robot::Driver driver(section.driver);

    // 2. Bus, heartbeat, subscriptions. Handlers hand over to the driver (thread-safe inputs).
    node::installShutdownHandlers();
    node::Bus bus(have_url ? url : cell.lcm.url, have_prefix ? prefix : cell.lcm.prefix);
    node::Heartbeat heartbeat(bus, "depowder-driver", opt.heartbeat_period_s);
    heartbeat.setStat("cell_model", node::cellModelId(cell));  // depowder-status compares hosts
    std::string input_problem;                                 // shown in the heartbeat for a while
    std::int64_t input_problem_ns = 0;                         // CLOCK_MONOTONIC when it happened
    bus.subscribe<nozzle_plan_t>("NOZZLE_PLAN", [&](const nozzle_plan_t& msg, const std::string&) {
      robot::Plan plan;
      std::string why;
      if (!robot::fromMsg(msg, &plan, &why)) {
        heartbeat.addDropped();
        input_problem = "plan " + std::to_string(msg.plan_id) + " refused: " + why;
        input_problem_ns = robot::bcap::monotonicNs();
        return;
      }
      const robot::PlanResult r = driver.submitPlan(plan);
      if (!r.accepted) {
        heartbeat.addDropped();
        input_problem = "plan " + std::to_string(msg.plan_id) + " refused: " + r.reason;
        input_problem_ns = robot::bcap::monotonicNs();
        std::cerr << "depowder-driver: " << input_problem << std::endl;
      }
    });
    // ESTOP on a bus of its own, handled in a thread of its own: it never waits behind a plan
    // being prepared (IK along the whole plan) or a ROBOT_STATE going out on the main thread.
    node::Bus estop_bus(have_url ? url : cell.lcm.url, have_prefix ? prefix : cell.lcm.prefix);
    estop_bus.subscribe<estop_t>("ESTOP", [&](const estop_t& msg, const std::string&) {
      driver.estop(msg.stop, msg.source + ": " + msg.reason);
      std::cerr << "depowder-driver: ESTOP " << (msg.stop ? "STOP" : "reset") << " from " << msg.source << ": "
                << msg.reason << std::endl;
    });
    std::atomic<bool> stop_estop{false};
    std::thread estop_listener;
    std::atomic<bool> stop_loop{false};
    std::thread loop;
    // However this scope is left (a bus error throws): the slave loop brakes the arm and gives
    // it back first, with ESTOP still obeyed, then the listener stops.
    struct Joiner {
      std::atomic<bool>& stop;
      std::thread& thread;
      ~Joiner() {
        stop = true;
        if (thread.joinable()) thread.join();
      }
    } join_estop{stop_estop, estop_listener}, join_loop{stop_loop, loop};
    estop_listener = std::thread([&] {
      while (!stop_estop) {
        try {
          estop_bus.spinOnce(50);
        } catch (const std::exception& e) {
          // Deaf to ESTOP: the arm is stopped as if one came (a reset cannot arrive any more).
          driver.estop(true, std::string("the ESTOP listener failed: ") + e.what());
          std::cerr << "depowder-driver: ESTOP listener failed, arm stopped: " << e.what() << std::endl;
          return;
        }
      }
    });
    // The planner's heartbeats: one planner, of this driver's arm and workspace (PlannerWatch).
    robot::PlannerWatch planners(robot::armModelId(section.driver.arm, section.driver.safety.workspace),
                                 section.driver.safety.planner_heartbeat_timeout_s);
    bus.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& msg, const std::string&) {
      if (msg.process != opt.planner_process) return;
      const double arm_model = node::heartbeatStat(msg, "arm_model");
      const std::string who = msg.host + ":" + std::to_string(msg.pid);
      driver.plannerHeartbeat(
          planners.heard(who, arm_model, msg.state == heartbeat_t::STOPPING, robot::bcap::monotonicNs() * 1e-9));
    });
    heartbeat.setState(heartbeat_t::STARTING, "connecting to the controller");
    heartbeat.publish();

    // 3. The slave loop in its own thread (real-time priority when allowed).
    loop = std::thread([&] { driver.run(stop_loop); });
    bool realtime = false;
    if (opt.realtime) {
      sched_param sp{};
      sp.sched_priority = 50;
      realtime = pthread_setschedparam(loop.native_handle(), SCHED_FIFO, &sp) == 0;
    }
    std::cout << "depowder-driver: controller " << section.driver.session.client.host << ":"
              << section.driver.session.client.port << ", cell " << cell.file
              << (realtime ? ", slave loop SCHED_FIFO" : ", slave loop normal priority") << std::endl;

    // 4. Main loop: LCM until the next ROBOT_STATE is due, then publish it.
    const std::int64_t period_ns = static_cast<std::int64_t>(1e9 / opt.state_rate_hz);
    std::int64_t next_state = robot::bcap::monotonicNs();
    std::string last_reason;
    while (!node::shutdownRequested()) {
      const std::int64_t wait_ns = next_state - robot::bcap::monotonicNs();
      if (wait_ns > 0) bus.spinOnce(static_cast<int>(std::max<std::int64_t>(wait_ns / 1000000, 0)));
      if (robot::bcap::monotonicNs() < next_state) continue;
      next_state += period_ns;
      if (next_state < robot::bcap::monotonicNs()) next_state = robot::bcap::monotonicNs() + period_ns;

      const robot::DriverStatus st = driver.status();
      bus.publish("ROBOT_STATE", toMsg(st, node::nowUtime()));
      if (st.reason != last_reason && st.mode != robot::DriverMode::Following) {
        std::cout << "depowder-driver: " << robot::toString(st.mode) << ": " << st.reason << std::endl;
      }
      last_reason = st.reason;

      for (const std::string& e : bus.takeErrors()) std::cerr << "depowder-driver: " << e << std::endl;
      for (const std::string& e : estop_bus.takeErrors()) std::cerr << "depowder-driver: ESTOP: " << e << std::endl;
      const robot::DriverStats& s = st.stats;
      heartbeat.setStat("mode", static_cast<double>(st.mode));
      heartbeat.setStat("exchanges", static_cast<double>(s.exchanges));
      heartbeat.setStat("plans_accepted", static_cast<double>(s.plans_accepted));
      heartbeat.setStat("plans_refused", static_cast<double>(s.plans_refused));
      heartbeat.setStat("plans_clipped", static_cast<double>(s.plans_clipped));
      heartbeat.setStat("commands_clipped", static_cast<double>(s.commands_clipped));
      heartbeat.setStat("safety_stops", static_cast<double>(s.safety_stops));
      heartbeat.setStat("estops", static_cast<double>(s.estops));
      heartbeat.setStat("reconnects", static_cast<double>(s.reconnects));
      heartbeat.setStat("faults", static_cast<double>(s.faults));
      heartbeat.setStat("realtime", realtime ? 1.0 : 0.0);
      heartbeat.setStat("follow_lag_ms", st.follow_lag_s * 1000);
      const bool fine = st.mode == robot::DriverMode::Idle || st.mode == robot::DriverMode::Following;
      const bool problem = !input_problem.empty() && robot::bcap::monotonicNs() - input_problem_ns < 2'000'000'000LL;
      if (!fine)  // with a plan just refused, say why it was (it may be why the arm stays put)
        heartbeat.setState(heartbeat_t::DEGRADED, std::string(robot::toString(st.mode)) + ": " + st.reason +
                                                      (problem ? "; " + input_problem : ""));
      else if (problem)
        heartbeat.setState(heartbeat_t::DEGRADED, input_problem);
      else
        heartbeat.setState(heartbeat_t::RUNNING);
      heartbeat.tick();
    }

    // 5. Orderly shutdown: the loop brakes the arm to rest, leaves slave mode, gives the arm
    // back, motor off, disconnects; ESTOP is obeyed until then.
    heartbeat.setState(heartbeat_t::STOPPING);
    heartbeat.publish();
    // (join_loop, then join_estop)
  } catch (const std::exception& e) {
    std::cerr << "depowder-driver: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
