// depowder-sim-physics-bench: does the simulator keep real time with the physics on and both
// cameras rendering? Runs scenarios as depowder-sim does (fixed steps, each camera at its rate with
// noise, SIM_TRUTH not published) and reports thread CPU time per simulated second: world steps
// (physics, tools, powder) and frames apart, and the real-time factor (simulated / CPU seconds; > 1
// keeps real time on one core). Also what happened: the pipe's fall, the push's outcome.
//   depowder-sim-physics-bench                      # default cell (buried pipe), push_cube, pipe_topple
//   depowder-sim-physics-bench --scenario config/scenarios/push_cube.yaml --duration 12
#include <time.h>

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "depowder/node/cell.hpp"
#include "setup.hpp"

using namespace depowder;
using namespace depowder::sim;

namespace {

double threadCpuS() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

void run(const std::string& cell, const std::string& scenario, double duration) {
  const SimSetup setup = loadSimSetup(cell, scenario);
  auto world = makeWorld(setup);
  NozzleScript script(setup.script, setup.script_loop);
  std::unique_ptr<PushScript> push = makePushScript(setup, *world);
  ArmSource* arm = push ? static_cast<ArmSource*>(push.get()) : &script;
  const double dt = 1.0 / setup.step_hz;
  std::vector<std::int64_t> due(world->cameras().size(), 1);
  double step_s = 0, render_s = 0, max_step_ms = 0, fall_time = -1;
  long frames = 0;
  const Pose T0 = world->partCount() ? world->part(0).T_cell_part : Pose::Identity();
  for (std::int64_t k = 1; k * dt <= duration + 1e-9; ++k) {
    const double t = k * dt;
    world->setArm(arm->update(t));
    const double c0 = threadCpuS();
    world->step(dt);
    const double c1 = threadCpuS();
    step_s += c1 - c0;
    max_step_ms = std::max(max_step_ms, (c1 - c0) * 1e3);
    for (std::size_t c = 0; c < due.size(); ++c) {
      const double rate = world->cameras()[c].rate_hz;
      if (t + 1e-9 < due[c] / rate) continue;
      while (due[c] / rate <= t + 1e-9) ++due[c];
      const double r0 = threadCpuS();
      world->render(c);
      render_s += threadCpuS() - r0;
      ++frames;
    }
    if (fall_time < 0 && world->partCount() &&
        rotationAngle(world->part(0).T_cell_part.linear(), T0.linear()) > 30 * M_PI / 180)
      fall_time = t;
  }
  const Truth truth = world->truth();
  const PartTruth& p = truth.parts.at(0);
  const Eigen::Vector3d up = p.T_cell_part.linear() * Eigen::Vector3d::UnitZ();
  std::printf("%s (%s)\n", scenario.empty() ? setup.cell_file.c_str() : scenario.c_str(),
              world->physics() ? "physics on" : "physics off");
  std::printf("  %.0f s simulated at %.0f Hz steps, %.0f Hz physics substeps, %zu cameras (%dx%d), %ld frames\n",
              duration, setup.step_hz, setup.config.physics.substep_hz, world->cameras().size(),
              world->cameras().empty() ? 0 : world->cameras()[0].width,
              world->cameras().empty() ? 0 : world->cameras()[0].height, frames);
  std::printf(
      "  thread CPU per simulated second: steps %.3f s (max step %.2f ms), frames %.3f s, total %.3f s"
      " -> real-time factor %.2f (%.0f %% of one core in real time)\n",
      step_s / duration, max_step_ms, render_s / duration, (step_s + render_s) / duration,
      duration / (step_s + render_s), 100 * (step_s + render_s) / duration);
  std::printf("  part '%s': moved %.1f cm, up (%.2f %.2f %.2f), tilted past 30 deg at %s, contacts %d", p.name.c_str(),
              100 * translationDistance(p.T_cell_part, T0), up.x(), up.y(), up.z(),
              fall_time < 0 ? "never" : (std::to_string(fall_time) + " s").c_str(), truth.contact_count);
  if (push) std::printf(", push: %s", toString(push->outcome()));
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string cell = node::defaultCellPath();
  std::vector<std::pair<std::string, double>> runs;
  double duration = -1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--config")
      cell = argv[i + 1];
    else if (a == "--scenario")
      runs.emplace_back(argv[i + 1], 0);
    else if (a == "--duration")
      duration = std::stod(argv[i + 1]);
    else {
      std::cerr << "usage: depowder-sim-physics-bench [--config FILE] [--scenario FILE]... [--duration S]\n";
      return 2;
    }
  }
  if (runs.empty()) {
    const std::string dir = cell.substr(0, cell.find_last_of('/') + 1) + "scenarios/";
    runs = {{"", 20}, {dir + "push_cube.yaml", 12}, {dir + "pipe_topple.yaml", 145}};
  }
  std::printf(
      "depowder-sim-physics-bench: thread CPU time (this process only; other load on the machine does not count)\n");
  for (const auto& [scenario, seconds] : runs)
    run(cell, scenario, duration > 0 ? duration : seconds > 0 ? seconds : 20);
  return 0;
}
