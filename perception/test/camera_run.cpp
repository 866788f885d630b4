#include "camera_run.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <mutex>
#include <thread>

#include "depowder/child_process.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depth_msg.hpp"

namespace depowder::perception::testing {

const char* const kListenUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

double CameraRunResult::stat(const std::string& name) const { return node::heartbeatStat(last_heartbeat, name); }

CameraRunResult runCamera(const CameraRunConfig& config) {
  using Clock = std::chrono::steady_clock;
  CameraRunResult result;
  std::mutex mutex;
  // A large receive buffer: this socket also gets every DEPTH frame on the group.
  node::Bus listener(kListenUrl, config.prefix);
  pid_t child_pid = -1;
  std::atomic<bool> started{false};
  listener.subscribe<point_cloud_t>("POINTS", [&](const point_cloud_t& msg, const std::string&) {
    result.clouds.push_back({msg, node::nowUtime()});
  });
  listener.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& msg, const std::string&) {
    if (msg.process != "depowder-camera" || msg.pid != child_pid) return;
    std::lock_guard<std::mutex> lock(mutex);
    result.last_heartbeat = msg;
    ++result.heartbeats;
    if (msg.state == heartbeat_t::RUNNING || msg.state == heartbeat_t::DEGRADED)
      result.cpu_percent.push_back(msg.cpu_percent);
    started = true;
  });

  std::vector<std::string> argv = {config.binary, "--prefix", config.prefix};
  argv.insert(argv.end(), config.extra_args.begin(), config.extra_args.end());
  testutil::ChildProcess child(argv, config.log_path);
  child_pid = child.pid();
  // Its first heartbeat says it is up and subscribed.
  for (auto end = Clock::now() + std::chrono::seconds(10); !started && Clock::now() < end;) listener.spinOnce(50);
  if (!started) {
    result.error = "depowder-camera sent no heartbeat within 10 s (see " + config.log_path + ")";
    return result;
  }

  // Messages are converted once; only utime and frame change per step.
  std::vector<std::vector<depth_image_t>> msgs(config.cameras.size());
  for (std::size_t c = 0; c < config.cameras.size(); ++c)
    for (const DepthImage& im : config.frames[c]) msgs[c].push_back(toMsg(im, config.cameras[c]));
  result.published_utimes.assign(static_cast<std::size_t>(config.steps),
                                 std::vector<std::int64_t>(config.cameras.size(), 0));
  std::atomic<bool> done{false};
  std::thread publisher([&] {
    node::Bus bus("", config.prefix);
    const auto t0 = Clock::now() + std::chrono::milliseconds(100);
    const std::int64_t t0_utime = node::nowUtime() + 100000;
    for (int step = 0; step < config.steps; ++step) {
      const double at = step / config.rate_hz;
      std::this_thread::sleep_until(t0 +
                                    std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(at)));
      // A step's frames are stamped at their capture time, every 1/rate, as a camera stamps
      // them, however late they are sent, and 1 ms a camera apart: the cameras capture together.
      // Stamped as sent, a frame sent late because publishing the one before it (a 150 kB
      // encode) was slow, as in a sanitized build under load, fell outside match_tolerance and
      // split its time step in two; and a step sent late came within match_tolerance of the
      // next, which then counted as late for the step published before it (a CI run: 74 of 75
      // steps out).
      const std::int64_t captured = t0_utime + static_cast<std::int64_t>(std::llround(at * 1e6));
      for (std::size_t c = 0; c < config.cameras.size(); ++c) {
        depth_image_t& msg = msgs[c][static_cast<std::size_t>(step) % msgs[c].size()];
        msg.frame = step;
        msg.utime = std::min(node::nowUtime(), captured + 1000 * static_cast<std::int64_t>(c));
        bool publish = true;
        if (config.fault) {
          depth_image_t copy = msg;
          publish = config.fault(step, static_cast<int>(c), copy, bus);
          if (publish) bus.publish("DEPTH_" + config.cameras[c].name, copy);
        } else {
          bus.publish("DEPTH_" + config.cameras[c].name, msg);
        }
        if (publish) result.published_utimes[static_cast<std::size_t>(step)][c] = msg.utime;
      }
    }
    done = true;
  });
  while (!done) listener.spinOnce(20);
  publisher.join();
  for (auto end = Clock::now() + std::chrono::duration<double>(config.grace_s); Clock::now() < end;)
    listener.spinOnce(20);
  // Stop it and collect its last (STOPPING) heartbeat.
  kill(child.pid(), SIGTERM);
  for (auto end = Clock::now() + std::chrono::seconds(3);
       Clock::now() < end && result.last_heartbeat.state != heartbeat_t::STOPPING;)
    listener.spinOnce(20);
  result.exit_code = child.wait(5.0);
  return result;
}

}  // namespace depowder::perception::testing
