// depowder-camera: depth frames (DEPTH_*) or recorded scans -> POINTS in the cell frame.
// A thin adapter: decode, call the perception library, encode, publish, report health.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <thread>

#include "camera_options.hpp"
#include "depowder/clock.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/perception/camera_proxy.hpp"
#include "depowder/perception/point_file.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/stats.hpp"
#include "depth_msg.hpp"

using namespace depowder;
using namespace depowder::perception;
using node::nowUtime;

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Says why frames are dropped on stderr without flooding it: one line per reason per second.
class ErrorLog {
 public:
  explicit ErrorLog(bool verbose) : verbose_(verbose) {}
  void report(const FrameError& e) {
    Entry& entry = entries_[e.status];
    const auto now = Clock::now();
    if (verbose_ || now - entry.last >= std::chrono::seconds(1)) {
      std::fprintf(stderr, "depowder-camera: dropped frame (%s): %s", toString(e.status), e.message.c_str());
      if (entry.suppressed > 0) std::fprintf(stderr, " [+%lld more since]", static_cast<long long>(entry.suppressed));
      std::fprintf(stderr, "\n");
      entry.last = now;
      entry.suppressed = 0;
    } else {
      ++entry.suppressed;
    }
  }

 private:
  struct Entry {
    Clock::time_point last{};
    long long suppressed = 0;
  };
  bool verbose_;
  std::map<FrameStatus, Entry> entries_;
};

// Percentiles of the last 300 samples of a figure.
class Window {
 public:
  void add(double v) {
    samples_.push_back(v);
    if (samples_.size() > 300) samples_.pop_front();
  }
  /// 0 before the first sample (a heartbeat figure).
  double percentile(double q) const {
    return samples_.empty() ? 0 : depowder::percentile({samples_.begin(), samples_.end()}, q);
  }

 private:
  std::deque<double> samples_;
};

class CameraNode {
 public:
  explicit CameraNode(const CameraNodeOptions& o)
      : options_(o),
        bus_(lcmUrl(o.cell.lcm.url, o.recv_buf_size), o.cell.lcm.prefix),
        heartbeat_(bus_, "depowder-camera", o.heartbeat_period),
        proxy_(o.perception, o.cell.box.size, knownCameras(o)),
        errors_(o.verbose) {}

  int run() {
    heartbeat_.setState(heartbeat_t::RUNNING);
    heartbeat_.setStat("cell_model", node::cellModelId(options_.cell));  // depowder-status compares hosts
    const int rc = options_.files.dir.empty() ? runLive() : runFiles();
    const std::string reason = updateHealth();
    heartbeat_.setState(heartbeat_t::STOPPING, reason.empty() ? "shutting down" : "shutting down; " + reason);
    heartbeat_.publish();
    return rc;
  }

 private:
  static std::vector<std::string> knownCameras(const CameraNodeOptions& o) {
    if (!o.files.dir.empty()) return {o.files.camera.name};
    std::vector<std::string> names;
    for (const auto& c : o.cell.cameras) names.push_back(c.name);
    return names;
  }

  // Live: every DEPTH_* frame is deprojected on arrival; clouds go out when their time step is ready.
  int runLive() {
    bus_.subscribe<depth_image_t>(options_.input, [this](const depth_image_t& msg, const std::string&) {
      const auto t0 = Clock::now();
      const std::int64_t arrival = node::steadyUtime();
      input_ms_.add(secondsBetween(nowUtime(), msg.utime) * 1e3);  // any utime: the proxy checks it
      DepthImage image;
      PinholeCamera camera;
      FrameError e = fromMsg(msg, image, camera);
      if (e.ok())
        e = proxy_.addDepth(image, camera, arrival);
      else
        proxy_.reject(e);
      if (!e.ok()) drop(e);
      pending_ms_ += msSince(t0);
    });
    // The self-filter's nozzle poses: the driver's forward kinematics of the measured joints.
    bus_.subscribe<robot_state_t>(options_.robot_state, [this](const robot_state_t& msg, const std::string&) {
      if (!msg.measured) return;  // the driver has not read the arm over its current connection
      if (const std::optional<Pose> T = node::fromMsg(msg.T_cell_nozzle)) {
        proxy_.addNozzlePose(msg.utime, *T);
        robot_heard_ = true;
      }
    });
    std::fprintf(stderr, "depowder-camera: %s -> %s (%zu cameras in %s)\n", bus_.channel(options_.input).c_str(),
                 bus_.channel(options_.output).c_str(), options_.cell.cameras.size(), options_.cell.file.c_str());
    while (!node::shutdownRequested()) {
      // Wake for the next frame, the oldest time step's deadline, or the heartbeat.
      int timeout_ms = 50;
      if (const std::int64_t deadline = proxy_.nextDeadline(); deadline > 0)
        timeout_ms = static_cast<int>(std::clamp<std::int64_t>((deadline - node::steadyUtime() + 999) / 1000, 0, 50));
      bus_.spinOnce(timeout_ms);
      bus_.drain();  // a camera's frame already in the socket is not late: read it before any deadline
      publishReady();
      for (const std::string& e : bus_.takeErrors()) std::fprintf(stderr, "depowder-camera: %s\n", e.c_str());
      updateHealth();
      heartbeat_.tick();
    }
    return 0;
  }

  // Files: one scan per period, in sorted order; an unreadable scan is reported and skipped.
  int runFiles() {
    const FilesConfig& f = options_.files;
    FileSource source(f.dir, f.loop);
    std::fprintf(stderr, "depowder-camera: %zu scans in %s at %.3g Hz -> %s\n", source.files().size(), f.dir.c_str(),
                 f.rate_hz, bus_.channel(options_.output).c_str());
    const auto period = std::chrono::duration<double>(1.0 / f.rate_hz);
    auto next_time = Clock::now();
    PointFile scan;
    while (!node::shutdownRequested()) {
      const auto t0 = Clock::now();
      if (!source.next(scan)) break;
      FrameError e = scan.error;
      if (e.ok())
        e = proxy_.addCameraPoints(scan.points, nowUtime(), f.camera, node::steadyUtime());
      else
        proxy_.reject(e);
      if (!e.ok()) drop(e);
      pending_ms_ += msSince(t0);
      publishReady();
      updateHealth();
      heartbeat_.tick();
      next_time += std::chrono::duration_cast<Clock::duration>(period);
      while (!node::shutdownRequested() && Clock::now() < next_time) {
        std::this_thread::sleep_for(std::min<Clock::duration>(next_time - Clock::now(), std::chrono::milliseconds(50)));
        heartbeat_.tick();
      }
    }
    return 0;
  }

  void drop(const FrameError& e) {
    heartbeat_.addDropped();
    errors_.report(e);
  }

  void publishReady() {
    const auto t0 = Clock::now();
    for (CellCloud& cloud : proxy_.poll(node::steadyUtime())) {
      int lost = 0;
      point_cloud_t msg = node::encodeCloud(cloud.points, cloud.utime, options_.perception.resolution, &lost);
      msg.seq = seq_++;
      msg.sources = cloud.sources;
      msg.source_utimes = cloud.source_utimes;
      msg.num_sources = static_cast<std::int32_t>(msg.sources.size());
      bus_.publish(options_.output, msg);
      frame_ms_.add(pending_ms_ + msSince(t0));
      pending_ms_ = 0;
      latency_ms_.add((nowUtime() - cloud.utime) / 1000.0);
      last_points_ = msg.num_points;
      last_bytes_ = msg.getEncodedSize();
      last_outliers_ = static_cast<double>(cloud.outliers);
      last_on_nozzle_ = static_cast<double>(cloud.on_nozzle);
      last_unfiltered_ = cloud.unfiltered;
    }
  }

  // Heartbeat figures and state; returns the reason it is DEGRADED ("" when healthy).
  std::string updateHealth() {
    const ProxyCounters& c = proxy_.counters();
    heartbeat_.setStat("frames_in", static_cast<double>(c.frames_in));
    heartbeat_.setStat("frames_out", static_cast<double>(c.frames_out));
    heartbeat_.setStat("frames_partial", static_cast<double>(c.partial_out));
    heartbeat_.setStat("frames_unfiltered", static_cast<double>(c.unfiltered_out));
    for (std::size_t s = 1; s < c.by_status.size(); ++s)
      heartbeat_.setStat(std::string("dropped_") + toString(static_cast<FrameStatus>(s)),
                         static_cast<double>(c.by_status[s]));
    heartbeat_.setStat("frame_ms_p50", frame_ms_.percentile(0.5));
    heartbeat_.setStat("frame_ms_p99", frame_ms_.percentile(0.99));
    heartbeat_.setStat("input_ms_p50", input_ms_.percentile(0.5));
    heartbeat_.setStat("input_ms_p99", input_ms_.percentile(0.99));
    heartbeat_.setStat("latency_ms_p50", latency_ms_.percentile(0.5));
    heartbeat_.setStat("latency_ms_p99", latency_ms_.percentile(0.99));
    heartbeat_.setStat("points_out", last_points_);
    heartbeat_.setStat("bytes_out", last_bytes_);
    heartbeat_.setStat("outliers_out", last_outliers_);
    heartbeat_.setStat("on_nozzle_out", last_on_nozzle_);
    heartbeat_.setStat("clock_restarts", static_cast<double>(proxy_.clockRestarts()));
    if (proxy_.clockRestarts() > reported_restarts_) {
      reported_restarts_ = proxy_.clockRestarts();
      std::fprintf(stderr, "depowder-camera: %s\n", proxy_.lastClockRestart().c_str());
    }
    std::string reason;
    for (const CameraHealth& h : proxy_.health(node::steadyUtime())) {
      heartbeat_.setStat("age_s_" + h.name, h.last_seen_age);
      heartbeat_.setStat("lag_s_" + h.name, h.utime_lag);
      if (h.silent && !h.refused.empty()) {
        reason += "camera " + h.name + " sends only frames refused (" + h.refused + "); ";
      } else if (h.silent) {
        reason += "camera " + h.name +
                  (h.last_seen_age < 0 ? std::string(" never seen")
                                       : " silent for " + std::to_string(static_cast<int>(h.last_seen_age)) + " s");
        reason += "; ";
      } else if (h.stale) {
        reason += "camera " + h.name + " stale (" + std::to_string(std::llround(h.utime_lag * 1000)) + " ms behind); ";
      }
    }
    // The arm's poses came once and none is near the frames now: the nozzle is in the clouds (the
    // driver stopped publishing, or its host's clock is off from the cameras').
    if (last_unfiltered_ && robot_heard_)
      reason += "frames not self-filtered: no " + bus_.channel(options_.robot_state) + " within " +
                std::to_string(std::lround(options_.perception.self_filter.max_age * 1000)) + " ms of their time; ";
    for (const auto& [name, a] : proxy_.agreement()) {
      if (!a.last.valid) continue;
      heartbeat_.setStat("apart_mm_" + name, 1000 * a.last.offset);
      heartbeat_.setStat("tilt_deg_" + name, a.last.tilt_deg);
      if (a.flagged) {
        std::ostringstream s;
        s << std::setprecision(2) << std::fixed << "cameras " << name << " and " << a.reference << " see the powder "
          << 1000 * a.last.offset << " mm apart and " << a.last.tilt_deg
          << " deg tilted: has one moved? (depowder-calibrate); ";
        reason += s.str();
      }
    }
    if (!c.last_error.ok() && c.dropped() > reported_drops_) {
      last_drop_time_ = Clock::now();
      reported_drops_ = c.dropped();
    }
    if (!c.last_error.ok() && Clock::now() - last_drop_time_ < std::chrono::seconds(5))
      reason += "last drop (" + std::string(toString(c.last_error.status)) + "): " + c.last_error.message;
    if (!reason.empty() && reason.size() >= 2 && reason.compare(reason.size() - 2, 2, "; ") == 0)
      reason.resize(reason.size() - 2);
    heartbeat_.setState(reason.empty() ? heartbeat_t::RUNNING : heartbeat_t::DEGRADED, reason);
    return reason;
  }

  const CameraNodeOptions& options_;
  node::Bus bus_;
  node::Heartbeat heartbeat_;
  CameraProxy proxy_;
  ErrorLog errors_;
  double pending_ms_ = 0;  ///< work on frames since the last published cloud
  Window frame_ms_;        ///< processing per published cloud: its frames' work plus merging and encoding
  Window input_ms_;        ///< DEPTH utime to its arrival here (transport)
  Window latency_ms_;      ///< newest source utime to POINTS published
  std::int64_t seq_ = 0;
  double last_points_ = 0, last_bytes_ = 0, last_outliers_ = 0, last_on_nozzle_ = 0;
  bool last_unfiltered_ = false;  ///< the last cloud published was not self-filtered
  bool robot_heard_ = false;      ///< a nozzle pose came on ROBOT_STATE
  std::int64_t reported_drops_ = 0;
  std::int64_t reported_restarts_ = 0;
  Clock::time_point last_drop_time_{};
};

}  // namespace

int main(int argc, char** argv) {
  std::optional<CameraNodeOptions> options;
  try {
    options = parseOptions(argc, argv);
    if (!options) {
      std::cout << usage();
      return 0;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-camera: %s\n", e.what());
    return 2;
  }
  node::installShutdownHandlers();
  try {
    CameraNode camera(*options);
    return camera.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-camera: %s\n", e.what());
    return 1;
  }
}
