// Safety timing of depowder-driver as a process, over udpm, against an in-process emulator.
// Run it inside a private network namespace (it refuses otherwise):
//   test/netns-run build/bin/depowder-driver-bench-safety
//   1. ESTOP publish -> the arm halted in the emulator (goal < 20 ms), --reps times.
//   2. Last planner heartbeat -> controlled stop started (ROBOT_STATE reason) and -> the arm at
//      rest in the emulator (goal: within planner_heartbeat_timeout + one 8 ms cycle), --reps / 4
//      times at each nozzle speed: a transit's 0.1 m/s and a vacuum loop's 0.03 m/s (config/cell.yaml),
//      whose stop takes a single cycle.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "depowder/estop_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "driver_process.hpp"

using namespace depowder;
using namespace depowder::robot;
using Clock = std::chrono::steady_clock;

namespace {
constexpr double kPi = 3.14159265358979323846;
Pose down(double x, double y, double z) { return makePoseRpy({x, y, z}, 0, kPi, 0); }
double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }
void summary(const char* what, std::vector<double> v) {
  std::sort(v.begin(), v.end());
  double mean = 0;
  for (double x : v) mean += x / v.size();
  std::printf("  %-46s n %zu  min %.2f  mean %.2f  p50 %.2f  max %.2f ms\n", what, v.size(), v.front(), mean,
              v[v.size() / 2], v.back());
}
}  // namespace

int main(int argc, char** argv) {
  int reps = 20;
  const double timeout_s = 1.0;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--reps" && i + 1 < argc) reps = std::max(1, std::atoi(argv[++i]));
  }
  // DriverProcess refuses outside a private network namespace (and fails if the emulator cannot bind).
  std::unique_ptr<test::DriverProcess> process;
  try {
    process = std::make_unique<test::DriverProcess>("  planner_heartbeat_timeout: " + std::to_string(timeout_s) +
                                                    "\n  plan_max_age: 30\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-driver-bench-safety: %s\n", e.what());
    return 2;
  }
  test::DriverProcess& p = *process;
  robot_state_t last{};
  p.bus->subscribe<robot_state_t>("ROBOT_STATE", [&](const robot_state_t& m, const std::string&) { last = m; });
  auto last_hb = Clock::now() - std::chrono::seconds(10);
  bool beating = true;
  auto tick = [&] {
    if (beating && Clock::now() - last_hb > std::chrono::milliseconds(500)) {  // a planner's 2 Hz
      p.plannerHeartbeat();
      last_hb = Clock::now();
    }
  };
  if (!p.spinUntil(
          [&] {
            tick();
            return last.mode == robot_state_t::MODE_IDLE;
          },
          10)) {
    std::fprintf(stderr, "driver did not come up: %s\n", last.mode_reason.c_str());
    return 1;
  }
  // The planner's first heartbeats; and LCM drops what is published before the driver's
  // receive socket has joined the group, so give it a moment.
  p.spinUntil(
      [&] {
        tick();
        return false;
      },
      1.0);
  // Back and forth across the box so that every repetition starts while the arm moves.
  std::int64_t id = 0;
  auto moving = [&](double speed) {
    p.spinUntil(
        [&] {
          tick();
          return false;
        },
        0.05);                                                           // a fresh heartbeat first
    const double x = last.T_cell_nozzle.position[0] > 0 ? -0.15 : 0.15;  // the far side: a long way to go
    p.bus->publish("NOZZLE_PLAN", p.plan(++id, {down(x, 0.0, 0.1)}, speed));
    if (!p.spinUntil(
            [&] {
              tick();
              return last.mode == robot_state_t::MODE_FOLLOWING;
            },
            3))
      return false;
    p.spinUntil(
        [&] {
          tick();
          return false;
        },
        0.3);  // well under way
    return true;
  };
  auto emuAtRest = [&] {
    const auto j = p.emu->joints();
    return std::all_of(j.qd.begin(), j.qd.end(), [](double v) { return v == 0.0; });
  };

  // 1. ESTOP.
  std::vector<double> estop_ms;
  for (int r = 0; r < reps; ++r) {
    if (!moving(0.1)) {
      std::fprintf(stderr, "plan not followed: %s\n", last.mode_reason.c_str());
      return 1;
    }
    estop_t e{};
    e.utime = node::nowUtime();
    e.source = "bench";
    e.stop = true;
    e.reason = "bench";
    const auto t0 = Clock::now();
    p.bus->publish("ESTOP", e);
    while (!p.emu->halted() && Clock::now() - t0 < std::chrono::seconds(1)) {
    }
    const auto h = p.emu->lastHaltTime();
    if (!p.emu->halted() || !h) {
      std::fprintf(stderr, "the arm was not halted within 1 s\n");
      return 1;
    }
    estop_ms.push_back(ms(t0, *h));
    p.spinUntil(
        [&] {
          tick();
          return last.mode == robot_state_t::MODE_ESTOPPED;
        },
        2);
    e.stop = false;
    p.bus->publish("ESTOP", e);
    p.spinUntil(
        [&] {
          tick();
          return last.mode == robot_state_t::MODE_IDLE;
        },
        3);
  }

  // 2. Planner heartbeat lost, at each speed.
  const std::vector<double> speeds = {0.1, 0.03};
  std::vector<std::vector<double>> initiated_ms(speeds.size()), rest_ms(speeds.size());
  const int hb_reps = std::max(1, reps / 4);
  for (int r = 0; r < hb_reps * static_cast<int>(speeds.size()); ++r) {
    const std::size_t k = static_cast<std::size_t>(r) % speeds.size();
    beating = true;
    if (!moving(speeds[k])) return 1;
    p.spinUntil(
        [&] {
          tick();
          return false;
        },
        0.6);
    beating = false;
    const auto t_last = last_hb;  // the last heartbeat sent
    Clock::time_point t_init{}, t_rest{};
    p.spinUntil(
        [&] {
          if (t_init == Clock::time_point{} && last.mode_reason.find("controlled stop") != std::string::npos)
            t_init = Clock::now();
          if (t_init != Clock::time_point{} && t_rest == Clock::time_point{} && emuAtRest()) t_rest = Clock::now();
          return t_rest != Clock::time_point{};
        },
        5);
    if (t_rest == Clock::time_point{}) {
      std::fprintf(stderr, "no controlled stop: %s\n", last.mode_reason.c_str());
      return 1;
    }
    initiated_ms[k].push_back(ms(t_last, t_init));
    rest_ms[k].push_back(ms(t_last, t_rest));
    beating = true;
  }
  p.terminate();

  std::printf("depowder-driver safety timing (process over udpm, emulator in-process, sync slave mode):\n");
  summary("ESTOP publish -> arm halted in the emulator", estop_ms);
  std::printf("    goal < 20 ms\n");
  for (std::size_t k = 0; k < speeds.size(); ++k) {
    std::printf("  the nozzle at %.2f m/s:\n", speeds[k]);
    summary("last planner heartbeat -> controlled stop begun", initiated_ms[k]);
    summary("last planner heartbeat -> arm at rest (emulator)", rest_ms[k]);
  }
  std::printf("    limit %.0f ms (planner_heartbeat_timeout) + one 8 ms cycle = %.0f ms\n", timeout_s * 1000,
              timeout_s * 1000 + 8);
  return 0;
}
