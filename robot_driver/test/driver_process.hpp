// depowder-driver as a process against an in-process b-CAP emulator, over udpm: for the
// process test and the safety benchmark. Only inside a private network namespace
// (test/netns-run), so the multicast never leaves it: elsewhere the constructor throws.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "depowder/child_process.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/robot/kinematics.hpp"
#include "depowder/sim/bcap_emulator.hpp"

namespace depowder::robot::test {

inline const char* kUdpmUrl = "udpm://239.255.76.67:7667?ttl=0";

class DriverProcess {
 public:
  /// `robot_yaml`: extra lines of the robot section (indented by two spaces).
  explicit DriverProcess(const std::string& robot_yaml = "") {
    if (const std::string refusal = testutil::multicastRefusal(); !refusal.empty())
      throw std::runtime_error("DriverProcess: " + refusal);
    sim::BcapEmulatorConfig ecfg;
    ecfg.port = 0;
    ecfg.motor_on_time_s = 0.02;
    emu = std::make_unique<sim::BcapEmulator>(ecfg);
    std::string err;
    if (!emu->start(&err)) throw std::runtime_error(err);
    std::ostringstream cell;
    cell << "robot:\n"
         << "  controller: {port: " << emu->port() << ", reconnect_period: 0.1}\n"
         << "  base_pose: {xyz: [-0.55, 0, 0], rpy_deg: [0, 0, 0]}\n"
         << "  tool_offset: {xyz: [0, 0, 0.129], rpy_deg: [0, 0, 0]}\n"
         << "  heartbeat_period: 0.2\n"
         << robot_yaml;
    arm.T_cell_base = makePoseRpy({-0.55, 0, 0}, 0, 0, 0);
    arm.T_flange_nozzle = makePoseRpy({0, 0, 0.129}, 0, 0, 0);
    process_.start(
        {"--cell", process_.write("cell.yaml", cell.str()), "--url", kUdpmUrl, "--prefix", process_.prefix()});
    bus = std::make_unique<node::Bus>(kUdpmUrl, process_.prefix());
  }
  ~DriverProcess() {
    bus.reset();
    emu->stop();  // then the driver, if still running, is stopped as process_ goes
  }
  /// SIGTERM and wait; the exit status (128 + the signal if one ended it).
  int terminate() { return process_.terminate(); }
  bool spinUntil(const std::function<bool()>& done, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!done() && std::chrono::steady_clock::now() < end) bus->spinOnce(2);
    return done();
  }
  /// A depowder-planner heartbeat from process `pid` on host "test"; with `arm_model` (its
  /// robot::armModelId) as a stat if >= 0.
  void plannerHeartbeat(double arm_model = -1, int pid = 1, std::int8_t state = heartbeat_t::RUNNING) {
    heartbeat_t h{};
    h.utime = node::nowUtime();
    h.process = "depowder-planner";
    h.host = "test";
    h.pid = pid;
    h.state = state;
    if (arm_model >= 0) {
      h.stat_names.push_back("arm_model");
      h.stat_values.push_back(arm_model);
    }
    h.num_stats = static_cast<std::int32_t>(h.stat_names.size());
    bus->publish("HEARTBEAT", h);
  }
  nozzle_plan_t plan(std::int64_t id, const std::vector<Pose>& poses, double speed, std::int8_t tool = 1) {
    nozzle_plan_t p;
    p.utime = node::nowUtime();
    p.plan_id = id;
    p.part = "test";
    p.phase = 0;
    p.reason = "test";
    for (const Pose& T : poses) {
      waypoint_t w;
      w.T_cell_nozzle = node::toMsg(T);
      w.tool = tool;
      w.speed = speed;
      for (double& q : w.q) q = 0;
      p.waypoints.push_back(w);
    }
    p.num_waypoints = static_cast<std::int32_t>(p.waypoints.size());
    return p;
  }
  Eigen::Vector3d emuNozzle() const { return forwardNozzle(arm, emu->joints().q).translation(); }

  std::unique_ptr<sim::BcapEmulator> emu;
  std::unique_ptr<node::Bus> bus;
  ArmConfig arm;

 private:
  testutil::ProcessUnderTest process_{"depowder-driver"};
};

}  // namespace depowder::robot::test
