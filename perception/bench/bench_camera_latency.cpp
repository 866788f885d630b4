// depowder-camera end to end, as a process, over udpm: 2 cameras x 30 fps x 640 x 480
// synthetic DEPTH frames for 60 s; prints POINTS lost, DEPTH-to-POINTS latency, message
// size, rate and the process's own processing time. Run it inside a private network
// namespace (it refuses otherwise):
//   test/netns-run build/bin/bench_camera_latency [--seconds 60] [--width 640 --height 480]
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "camera_run.hpp"
#include "depowder/child_process.hpp"
#include "depowder/stats.hpp"
#include "synthetic.hpp"

using namespace depowder;
using namespace depowder::perception;
using namespace depowder::perception::testing;
using namespace depowder::testutil;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  double seconds = 60, rate = 30;
  int width = 640, height = 480;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--rate")) rate = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--width")) width = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--height")) height = std::atoi(argv[i + 1]);
  }
  if (!privateNetworkOrRefuse("bench_camera_latency")) return 2;
  const fs::path bin = fs::canonical("/proc/self/exe").parent_path();
  const fs::path tmp = fs::temp_directory_path() / ("depowder_bench_camera_" + std::to_string(::getpid()));
  fs::create_directories(tmp);
  // The default cell's geometry with cameras at the benchmark's resolution.
  const std::string cell = (tmp / "cell.yaml").string();
  {
    std::ofstream y(cell);
    y << "box: {size: [0.40, 0.30, 0.20], wall: 0.01}\ncameras:\n";
    for (const char* name : {"LEFT", "RIGHT"})
      y << "  - {name: " << name << ", width: " << width << ", height: " << height
        << ", fov_h_deg: 70, fov_v_deg: 55, rate_hz: " << rate << ", min_range: 0.25, max_range: 9.0, "
        << "position: [0.0, " << (name[0] == 'L' ? "-0.45" : "0.45") << ", 0.55], look_at: [0.0, 0.0, 0.05]}\n";
  }
  // Ten noisy frame pairs (cell.yaml's L515 noise, flying pixels), cycled.
  const auto cams = synthetic::defaultRig(width, height);
  const auto scene = synthetic::boxScene({0.40, 0.30, 0.20}, 0.08,
                                         {synthetic::Sphere{{0.02, 0.01, 0.09}, 0.045}, {{-0.1, -0.05, 0.07}, 0.03}});
  std::mt19937 rng(11);
  synthetic::Noise noise;
  noise.flying_pixel_prob = 0.3;
  CameraRunConfig run;
  run.binary = (bin / "depowder-camera").string();
  run.extra_args = {"--cell", cell};
  run.prefix = "BENCH" + std::to_string(::getpid()) + "_";
  run.log_path = (tmp / "camera.log").string();
  run.steps = static_cast<int>(seconds * rate);
  run.rate_hz = rate;
  run.cameras = cams;
  run.frames.resize(2);
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 2; ++c) run.frames[c].push_back(synthetic::render(scene, cams[c], 0, 0.00025, &noise, &rng));

  std::printf("depowder-camera: 2 cameras x %.0f fps x %dx%d for %.0f s (%d time steps), udpm in a private netns\n",
              rate, width, height, seconds, run.steps);
  const CameraRunResult r = runCamera(run);
  if (!r.error.empty()) {
    std::fprintf(stderr, "%s\n", r.error.c_str());
    return 1;
  }
  std::vector<double> latency_ms, bytes;
  long long gaps = 0;
  for (std::size_t i = 0; i < r.clouds.size(); ++i) {
    const auto& c = r.clouds[i];
    latency_ms.push_back((c.receive_utime - c.msg.utime) / 1000.0);
    bytes.push_back(static_cast<double>(c.msg.getEncodedSize()));
    if (i > 0) gaps += c.msg.seq - r.clouds[i - 1].msg.seq - 1;
  }
  // Lost = published by depowder-camera (its last heartbeat) but not received here.
  const long long published = static_cast<long long>(r.stat("frames_out"));
  const long long lost = published - static_cast<long long>(r.clouds.size());
  const double span_s =
      r.clouds.size() > 1 ? (r.clouds.back().receive_utime - r.clouds.front().receive_utime) * 1e-6 : 0.0;
  const double p99 = percentile(latency_ms, 0.99);
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  std::printf("  DEPTH time steps sent      %d (%d messages of %.0f kB)\n", run.steps, 2 * run.steps,
              width * height * 2 / 1000.0);
  std::printf("  POINTS published           %lld (partial: %g; depowder-camera dropped %lld frames)\n", published,
              r.stat("frames_partial"), static_cast<long long>(r.last_heartbeat.dropped));
  std::string reasons;
  for (std::size_t i = 0; i < r.last_heartbeat.stat_names.size(); ++i)
    if (r.last_heartbeat.stat_names[i].rfind("dropped_", 0) == 0 && r.last_heartbeat.stat_values[i] > 0)
      reasons += " " + r.last_heartbeat.stat_names[i].substr(8) + " " +
                 std::to_string(static_cast<long long>(r.last_heartbeat.stat_values[i]));
  std::printf("  DEPTH frames used          %g of %d%s%s\n", r.stat("frames_in") - r.last_heartbeat.dropped,
              2 * run.steps, reasons.empty() ? "" : "; dropped:", reasons.c_str());
  std::printf("  POINTS received            %zu   lost %lld   seq gaps %lld\n", r.clouds.size(), lost, gaps);
  std::printf("  POINTS rate                %.2f Hz\n", span_s > 0 ? (r.clouds.size() - 1) / span_s : 0.0);
  std::printf("  POINTS size                median %.0f B, max %.0f B (%.1f kB)\n", percentile(bytes, 0.5),
              percentile(bytes, 1.0), percentile(bytes, 1.0) / 1000);
  std::printf("  DEPTH-to-POINTS latency    p50 %.2f ms   p99 %.2f ms   max %.2f ms\n", percentile(latency_ms, 0.5),
              p99, percentile(latency_ms, 1.0));
  std::printf(
      "  depowder-camera (last 300) DEPTH in p50 %.2f p99 %.2f ms, processing p50 %.2f p99 %.2f ms, DEPTH-to-"
      "publish p50 %.2f p99 %.2f ms\n",
      r.stat("input_ms_p50"), r.stat("input_ms_p99"), r.stat("frame_ms_p50"), r.stat("frame_ms_p99"),
      r.stat("latency_ms_p50"), r.stat("latency_ms_p99"));
  std::printf("  depowder-camera CPU        %.0f %% of a core (median of its heartbeats)\n",
              percentile(r.cpu_percent, 0.5));
  std::printf("  machine                    load average %.1f %.1f %.1f on %ld cores\n", load[0], load[1], load[2],
              sysconf(_SC_NPROCESSORS_ONLN));
  const bool ok = lost == 0 && gaps == 0 && p99 < 15.0 && percentile(bytes, 1.0) < 1e6;
  std::printf("  goals (no POINTS lost, p99 < 15 ms, < 1 MB): %s\n", ok ? "met" : "MISSED");
  fs::remove_all(tmp);
  return ok ? 0 : 1;
}
