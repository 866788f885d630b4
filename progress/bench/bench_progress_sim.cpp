// depowder-progress-sim-bench: the progress estimator on frames of the simulator (sim/), against
// the simulator's own true eta (Eq. 2 on its powder height field). Each default part at 4 yaws,
// dug to visibility 0, 10, ..., 100 % (World::digToVisibility), seen by the cell's two cameras
// with their noise, cropped to the box and voxel-downsampled like the camera proxy does; with no
// nozzle, and with the nozzle hovering beside the part 1.5 cm above the powder.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "depowder/node/cell.hpp"
#include "depowder/parts.hpp"
#include "depowder/point_grid.hpp"
#include "depowder/progress/progress.hpp"
#include "depowder/sim/world.hpp"
#include "depowder/stats.hpp"
#include "setup.hpp"  // sim::cameraModelOf

using namespace depowder;

int main(int argc, char** argv) {
  std::string cell_path = node::defaultCellPath();
  int yaws = 4;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--cell" && i + 1 < argc) {
      cell_path = argv[++i];
    } else if (a == "--yaws" && i + 1 < argc) {
      yaws = std::max(1, std::atoi(argv[++i]));
    } else {
      std::cerr << "usage: depowder-progress-sim-bench [--cell FILE] [--yaws N]\n";
      return a == "--help" ? 0 : 2;
    }
  }
  const node::CellConfig cell = node::loadCell(cell_path);
  std::vector<sim::CameraModel> cameras;
  for (const node::CameraConfig& c : cell.cameras) cameras.push_back(sim::cameraModelOf(c));
  sim::BoxGeometry box{cell.box.size, cell.box.wall};
  const sim::SimConfig sim_config;
  const double cad_spacing = 0.003, voxel = 0.005;
  Eigen::AlignedBox3d crop(Eigen::Vector3d(-0.5 * box.size.x(), -0.5 * box.size.y(), 0.0),
                           Eigen::Vector3d(0.5 * box.size.x(), 0.5 * box.size.y(), box.size.z()));
  crop.min().array() -= 0.01;
  crop.max().array() += 0.01;

  std::printf(
      "depowder-progress-sim-bench: simulator frames, %zu cameras from %s, voxel %.0f mm; the true band is\n"
      "  (%.1f, %.1f] cm from the footprint, so band_offset = %.1f cm - xi\n",
      cameras.size(), cell.file.c_str(), voxel * 1e3, sim_config.truth.band_inner * 100,
      sim_config.truth.band_outer * 100, sim_config.truth.band_inner * 100);
  std::printf("%-10s %-7s %6s | %6s %6s %6s | %8s %8s %8s | %7s %7s | %s\n", "part", "nozzle", "frames", "med", "p95",
              "max", "cz_med", "cz_p95", "cz_max", "ms_med", "ms_p95", "no_contour");
  std::vector<double> all_err, all_cz, all_ms;
  for (const std::string& name : parts::names()) {
    const Mesh mesh = parts::byName(name);
    const double xi = name == "propeller" || name == "pipe" ? 0.008 : 0.010;  // paper Sec. V-A
    progress::ProgressConfig config;
    config.band_offset = sim_config.truth.band_inner - xi;
    config.band_width = sim_config.truth.band_outer - sim_config.truth.band_inner;
    const Cloud cad = sampleSurface(mesh, cad_spacing).points;
    for (bool with_nozzle : {false, true}) {
      std::vector<double> err, cz, ms;
      int frames = 0, no_contour = 0;
      for (int k = 0; k < yaws; ++k) {
        const Pose R = makePoseRpy({0, 0, 0}, 0, 0, 0.3 + 2 * M_PI * k / yaws);
        const Eigen::AlignedBox3d b = bounds(transformed(mesh, R));
        Pose T = R;
        T.translation() = Eigen::Vector3d(0.01 - b.center().x(), -0.005 - b.center().y(), 0.03 - b.min().z());
        for (int level = 0; level <= 10; ++level) {
          sim::World world(sim_config, box, {{name, mesh, T, 1000}}, cameras, 100 * k + level + 1);
          world.digToVisibility(0, 0.1 * level);
          if (with_nozzle) {
            const Eigen::Vector2d xy =
                b.center().head<2>() + T.translation().head<2>() + Eigen::Vector2d(0.5 * b.sizes().x() + 0.025, 0.0);
            Pose T_cell_nozzle = makePoseRpy({0, 0, 0}, M_PI, 0, 0);  // +z (spray) down
            T_cell_nozzle.translation() << xy, world.powder().surfaceAt(xy) + 0.015;
            world.setNozzle(T_cell_nozzle, Tool::kOff);
          } else {
            world.removeNozzle();
          }
          Cloud seen;
          for (std::size_t c = 0; c < cameras.size(); ++c)
            for (const Point& p : world.render(c).cellCloud())
              if (crop.contains(p)) seen.push_back(p);
          const Cloud scan = voxelDownsample(seen, voxel);
          const sim::PartTruth truth = world.partTruth(0);
          ++frames;
          progress::ProgressEstimate e;
          double best_ms = 1e9;  // wall time with P_cad . T_i, best of 3 (the machine is shared)
          for (int r = 0; r < 3; ++r) {
            const auto t0 = std::chrono::steady_clock::now();
            e = progress::estimateProgress(transformed(cad, T), scan, xi, config);
            best_ms = std::min(
                best_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          }
          ms.push_back(best_ms);
          if (e.status != progress::Status::kOk) {
            ++no_contour;
            continue;
          }
          err.push_back(100 * std::abs(e.eta - truth.eta));
          for (const Point& p : e.contour) cz.push_back(100 * std::abs(p.z() - world.powder().surfaceAt(p.head<2>())));
        }
      }
      std::printf("%-10s %-7s %6d | %6.2f %6.2f %6.2f | %6.2fcm %6.2fcm %6.2fcm | %7.3f %7.3f | %d\n", name.c_str(),
                  with_nozzle ? "beside" : "none", frames, interpolatedPercentile(err, 0.5),
                  interpolatedPercentile(err, 0.95), interpolatedPercentile(err, 1.0), interpolatedPercentile(cz, 0.5),
                  interpolatedPercentile(cz, 0.95), interpolatedPercentile(cz, 1.0), interpolatedPercentile(ms, 0.5),
                  interpolatedPercentile(ms, 0.95), no_contour);
      all_err.insert(all_err.end(), err.begin(), err.end());
      all_cz.insert(all_cz.end(), cz.begin(), cz.end());
      all_ms.insert(all_ms.end(), ms.begin(), ms.end());
    }
  }
  std::printf("%-10s %-7s %6zu | %6.2f %6.2f %6.2f | %6.2fcm %6.2fcm %6.2fcm | %7.3f %7.3f |\n", "ALL", "",
              all_ms.size(), interpolatedPercentile(all_err, 0.5), interpolatedPercentile(all_err, 0.95),
              interpolatedPercentile(all_err, 1.0), interpolatedPercentile(all_cz, 0.5),
              interpolatedPercentile(all_cz, 0.95), interpolatedPercentile(all_cz, 1.0),
              interpolatedPercentile(all_ms, 0.5), interpolatedPercentile(all_ms, 0.95));
  std::printf(
      "  |eta error| in percentage points (goal: median <= 5, p95 <= 10); cz: contour vertex height minus the\n"
      "  simulator's surface there (goal <= 1 cm); ms: wall time per part per frame (best of 3; goal < 1 ms)\n");
  return 0;
}
