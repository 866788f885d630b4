// depowder-camera's settings: the cell YAML's `perception` section, then the command line.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "depowder/node/cell.hpp"
#include "depowder/perception/config.hpp"
#include "depowder/perception/depth.hpp"

namespace depowder::perception {

/// Recorded scans instead of live DEPTH_* messages (YAML `perception.files`, or --files).
struct FilesConfig {
  std::string dir;       ///< directory of .pcd / .ply files; "" = live mode
  double rate_hz = 10;   ///< scans published per second
  bool loop = false;     ///< start over after the last file
  PinholeCamera camera;  ///< name, pose (T_cell_camera) and range limits (distance from the camera) of the scans;
                         ///< intrinsics unused
};

struct CameraNodeOptions {
  explicit CameraNodeOptions(node::CellConfig c) : cell(std::move(c)) {}
  node::CellConfig cell;
  PerceptionConfig perception;
  std::string input = "DEPTH_.*";  ///< LCM channel regex of the depth frames (before the prefix)
  std::string output = "POINTS";
  std::string robot_state = "ROBOT_STATE";  ///< nozzle poses for the self-filter (before the prefix)
  double heartbeat_period = 0.5;  ///< s
  int recv_buf_size = 4 << 20;    ///< bytes of UDP receive buffer asked of LCM's udpm (depth frames are
                                  ///< 150-600 kB each); the kernel caps it at net.core.rmem_max; 0 = LCM default
  FilesConfig files;
  bool verbose = false;
};

/// The cell's `perception` section alone (no command line); throws node::ConfigError naming the
/// file, key and range. depowder-eval takes its camera-proxy settings from here too.
CameraNodeOptions readCameraOptions(node::CellConfig cell);

/// Parses argv (see usage()); throws node::ConfigError (bad YAML) or std::invalid_argument
/// (bad command line) with a message naming what is wrong. Returns nullopt for --help.
std::optional<CameraNodeOptions> parseOptions(int argc, char** argv);

std::string usage();

/// The LCM URL to open: `url`, else $LCM_DEFAULT_URL, else LCM's default udpm URL; for udpm
/// without its own recv_buf_size, `recv_buf_size` is added (unless 0).
std::string lcmUrl(const std::string& url, int recv_buf_size);

}  // namespace depowder::perception
