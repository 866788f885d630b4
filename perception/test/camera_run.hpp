// One run of depowder-camera as a separate process: this process publishes DEPTH_<CAM>
// frames on a schedule (one thread) and records POINTS and HEARTBEAT (another), over udpm.
// Only call it inside a private network namespace (see testutil::inPrivateNetwork()).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "depowder/depth_image_t.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/perception/depth.hpp"
#include "depowder/point_cloud_t.hpp"

namespace depowder::perception::testing {

struct CameraRunConfig {
  std::string binary;                   ///< path of depowder-camera
  std::vector<std::string> extra_args;  ///< e.g. {"--cell", path}
  std::string prefix;                   ///< channel prefix shared by everyone in the run
  std::string log_path;                 ///< depowder-camera's stdout + stderr
  int steps = 90;                       ///< time steps published
  double rate_hz = 30;
  std::vector<PinholeCamera> cameras;           ///< one DEPTH_<NAME> stream each, published in this order
  std::vector<std::vector<DepthImage>> frames;  ///< per camera, cycled through step by step
  /// Called for every frame before it is published (copy of the message); return false to
  /// not publish it (the hook may publish something else on `bus` instead).
  std::function<bool(int step, int camera, depth_image_t& msg, node::Bus& bus)> fault;
  double grace_s = 1.0;  ///< listening after the last step
};

struct ReceivedCloud {
  point_cloud_t msg;
  std::int64_t receive_utime = 0;
};

struct CameraRunResult {
  std::vector<ReceivedCloud> clouds;
  std::vector<std::vector<std::int64_t>> published_utimes;  ///< [step][camera], 0 = not published
  heartbeat_t last_heartbeat;                               ///< the last one depowder-camera sent (STOPPING at the end)
  int heartbeats = 0;
  std::vector<double> cpu_percent;             ///< of every RUNNING / DEGRADED heartbeat
  int exit_code = -1;                          ///< of depowder-camera after SIGTERM
  std::string error;                           ///< set when the run could not be carried out
  double stat(const std::string& name) const;  ///< a heartbeat stat, NaN if absent
};

CameraRunResult runCamera(const CameraRunConfig& config);

/// LCM's default udpm group with a 4 MiB receive buffer (for listeners on a busy group).
extern const char* const kListenUrl;

}  // namespace depowder::perception::testing
