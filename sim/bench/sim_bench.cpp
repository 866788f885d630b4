// depowder-sim-bench: what the simulator costs on one core. Renders the default cell's two
// cameras at 320x240 and 640x480 (noise-free: the rasteriser alone; noisy: as published),
// and times world steps with the vacuum digging (tools + relaxation + contacts).
// Budget (issue 3): both cameras at 30 fps on at most one core, i.e. 60 frames in < 1 s.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "depowder/node/cell.hpp"
#include "setup.hpp"

using namespace depowder;
using namespace depowder::sim;

namespace {

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double wallMs() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Per-call figures, ms. On a shared machine the wall time includes waiting for the CPU; the
// thread's CPU time does not, and its median is what a frame costs on one core.
struct Timing {
  double wall = 0;     ///< mean wall time
  double cpu_p50 = 0;  ///< median thread CPU time
  double cpu_min = 0;  ///< fastest call (thread CPU time)
};

template <class Fn>
Timing time(int n, Fn&& fn) {
  std::vector<double> cpu(n);
  const double w0 = wallMs();
  for (int i = 0; i < n; ++i) {
    const double c0 = threadCpuMs();
    fn(i);
    cpu[i] = threadCpuMs() - c0;
  }
  Timing t;
  t.wall = (wallMs() - w0) / n;
  std::sort(cpu.begin(), cpu.end());
  t.cpu_p50 = cpu[n / 2];
  t.cpu_min = cpu[0];
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  std::string config = node::defaultCellPath();
  int frames = 150, steps = 1200;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--config")
      config = argv[i + 1];
    else if (a == "--frames")
      frames = std::max(1, std::stoi(argv[i + 1]));
    else if (a == "--steps")
      steps = std::max(1, std::stoi(argv[i + 1]));
    else {
      std::cerr << "usage: depowder-sim-bench [--config FILE] [--frames N] [--steps N]\n";
      return 2;
    }
  }
  const SimSetup base = loadSimSetup(config);
  std::printf("Figures: thread CPU time per frame, median and minimum; mean wall time in brackets.\n");
  std::printf("depowder-sim-bench: cell %s, %zu parts, %zu cameras, powder cell %.1f mm, %d frames per camera\n",
              base.cell_file.c_str(), base.parts.size(), base.cameras.size(), base.config.powder.cell_size * 1e3,
              frames);

  // A nozzle in view of both cameras, over the part, so frames show everything they will in a run.
  NozzleScript script(base.script, base.script_loop);
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{320, 240}, {640, 480}}) {
    SimSetup setup = base;
    for (auto& c : setup.cameras) {
      const double fov_h = 2 * std::atan(0.5 * c.width / c.fx) * 180 / M_PI;
      const double fov_v = 2 * std::atan(0.5 * c.height / c.fy) * 180 / M_PI;
      CameraModel r = CameraModel::fromFov(c.name, w, h, fov_h, fov_v, c.T_cell_camera);
      r.min_range = c.min_range;
      r.max_range = c.max_range;
      r.noise = c.noise;
      c = r;
    }
    auto world = makeWorld(setup);
    world->setArm(script.at(3.0));
    std::printf("\n%dx%d\n", w, h);
    double both_noisy = 0;
    for (std::size_t c = 0; c < setup.cameras.size(); ++c) {
      world->render(c);  // warm-up (buffers, powder mesh)
      const Timing clean = time(frames, [&](int) { world->render(c, nullptr); });
      const Timing noisy = time(frames, [&](int) { world->render(c); });
      both_noisy += noisy.cpu_p50;
      std::printf(
          "  camera %-6s  noise-free %6.2f ms (min %6.2f)  published, with noise %6.2f ms (min %6.2f)"
          "  [wall %6.2f ms]  -> %6.1f frames/s on one core\n",
          setup.cameras[c].name.c_str(), clean.cpu_p50, clean.cpu_min, noisy.cpu_p50, noisy.cpu_min, noisy.wall,
          1000.0 / noisy.cpu_p50);
    }
    std::printf("  both cameras at 30 fps: %.1f %% of one core (budget: 100 %%)\n", 30.0 * both_noisy / 10.0);
  }

  // Steps with the vacuum digging along the cell's scripted path (default cell: orbits around the pipe).
  auto world = makeWorld(base);
  const double dt = 1.0 / base.step_hz;
  std::vector<double> ms;
  ms.reserve(steps);
  for (int k = 1; k <= steps; ++k) {
    world->setArm(script.at(k * dt));
    const double c0 = threadCpuMs();
    world->step(dt);
    ms.push_back(threadCpuMs() - c0);
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  double mean = 0;
  for (double m : ms) mean += m;
  mean /= ms.size();
  std::printf(
      "\nworld step, thread CPU time (%d steps at %.0f Hz, tool %s): mean %.3f ms, p50 %.3f ms, p99 %.3f ms, max %.3f "
      "ms"
      " -> %.1f %% of one core in real time; removed %.1f cm^3\n",
      steps, base.step_hz, toString(world->tool()), mean, sorted[sorted.size() / 2], sorted[sorted.size() * 99 / 100],
      sorted.back(), mean * base.step_hz / 10.0, world->truth().powder_removed_m3 * 1e6);
  return 0;
}
