// The camera proxy pipeline, one call per camera frame and one poll per loop:
//   frame -> deproject / to cell -> crop -> merge cameras by utime -> self-filter (the nozzle) -> voxel grid
//   -> isolated-voxel removal -> one cloud per time step.
// No LCM, YAML or file IO: depowder-camera feeds it, tests and benchmarks call it.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "depowder/perception/config.hpp"
#include "depowder/perception/depth.hpp"
#include "depowder/perception/frame_merger.hpp"
#include "depowder/perception/voxel_grid.hpp"

namespace depowder::perception {

/// One published time step.
struct CellCloud {
  std::int64_t utime = 0;  ///< newest source utime (what POINTS carries)
  std::vector<std::string> sources;
  std::vector<std::int64_t> source_utimes;
  std::vector<std::string> missing;  ///< expected cameras that did not contribute
  Cloud points;                      ///< cell frame, cropped, downsampled, outliers removed
  std::size_t points_in = 0;         ///< cropped points of all sources before downsampling
  std::size_t outliers = 0;          ///< voxels removed as isolated
  std::size_t on_nozzle = 0;         ///< cropped points removed as the nozzle's (self-filter)
  bool unfiltered = false;           ///< self-filter on, but no nozzle pose within its max_age
};

/// How a camera's powder heights compare with the reference camera's (the first by name),
/// at the newest check (config.agreement).
struct CameraAgreement {
  std::string reference;
  Agreement last;        ///< the newest check's figures (last.valid: enough cells seen by both)
  int over = 0;          ///< checks in a row beyond max_offset or max_tilt_deg
  bool flagged = false;  ///< over >= flag_after: the camera, or the reference, has probably moved
};

struct ProxyCounters {
  std::int64_t frames_in = 0;       ///< camera frames offered
  std::int64_t frames_out = 0;      ///< time steps released
  std::int64_t partial_out = 0;     ///< ... of which some expected camera was missing
  std::int64_t unfiltered_out = 0;  ///< ... of which not self-filtered: no nozzle pose near their time
  StatusCounts by_status{};         ///< frames offered, by outcome (kOk = used)
  FrameError last_error;            ///< the most recent rejection
  std::int64_t dropped() const;     ///< every frame whose status is not kOk
};

class CameraProxy {
 public:
  /// Cameras kept (known and seen): a frame of a further camera name is refused (kBadHeader), as
  /// each name holds its own rays and health figures and a stream of mis-set names would exhaust memory.
  static constexpr std::size_t kMaxCameras = 16;

  /// `box_size`: interior of the build box (m); `known_cameras` as FrameMerger's.
  CameraProxy(const PerceptionConfig& config, const Eigen::Vector3d& box_size,
              std::vector<std::string> known_cameras = {});

  /// A depth frame of `camera`, arrived at wall-clock `arrival` (us). One stamped outside 0 to
  /// 2^53 us (kMaxUtime, depowder/clock.hpp), or of a camera without a name or beyond kMaxCameras, is
  /// refused (kBadHeader); addNozzlePose ignores a pose stamped so.
  FrameError addDepth(const DepthImage& image, const PinholeCamera& camera, std::int64_t arrival);

  /// A recorded scan: camera-frame points captured at `utime` by `camera` (pose and range used).
  FrameError addCameraPoints(const Cloud& camera_points, std::int64_t utime, const PinholeCamera& camera,
                             std::int64_t arrival);

  /// Counts a frame that never reached the pipeline (e.g. a file that could not be read).
  void reject(const FrameError& error);

  /// The nozzle's pose at `utime` (ROBOT_STATE): points on it are removed from the time steps
  /// nearest it (config.self_filter). Poses are kept in time order, however they come (the
  /// newest kNozzlePoses); one so much older than the newest that the robot's clock went back
  /// (depowder/clock.hpp) starts them over.
  void addNozzlePose(std::int64_t utime, const Pose& T_cell_nozzle);
  /// Clouds ready at wall-clock `now`, oldest first.
  std::vector<CellCloud> poll(std::int64_t now);

  std::int64_t nextDeadline() const { return merger_.nextDeadline(); }
  /// The merger's health of each camera; a silent one whose frames come but are refused before
  /// merging (a bad header, absurd intrinsics) says so, with the last one's reason.
  std::vector<CameraHealth> health(std::int64_t now) const;
  /// Times the cameras' clock went back and the time steps started over (FrameMerger), and the last, said.
  std::int64_t clockRestarts() const { return merger_.restarts(); }
  const std::string& lastClockRestart() const { return merger_.lastRestart(); }
  const ProxyCounters& counters() const { return counters_; }
  /// Each camera's agreement with the reference, by camera name (none until two cameras were checked).
  const std::map<std::string, CameraAgreement>& agreement() const { return agreement_; }
  const Eigen::AlignedBox3d& crop() const { return crop_; }
  const PerceptionConfig& config() const { return config_; }
  /// Cameras whose deprojection tables are kept (about 8 bytes a pixel each): the merger's only.
  std::size_t deprojectionTables() const { return deprojectors_.size(); }

 private:
  /// Why a frame of this camera is refused by its name (kOk when it is taken).
  FrameError nameError(const std::string& camera) const;
  FrameError accept(CameraCloud&& cloud, const std::string& camera, std::int64_t utime, std::int64_t arrival);
  CellCloud finish(MergedFrame&& merged);
  void checkAgreement(const MergedFrame& merged);
  const Pose* nozzleAt(std::int64_t utime) const;

  PerceptionConfig config_;
  Eigen::AlignedBox3d crop_;
  std::map<std::string, Deprojector> deprojectors_;  ///< per camera name
  std::vector<Cloud> spare_;                         ///< released clouds, their capacity reused
  FrameMerger merger_;
  VoxelGrid grid_;
  ProxyCounters counters_;
  static constexpr std::size_t kNozzlePoses = 256;          ///< 2 s of ROBOT_STATE at 125 Hz
  std::deque<std::pair<std::int64_t, Pose>> nozzle_poses_;  ///< the newest ROBOT_STATE poses, oldest first
  Eigen::Vector3d box_size_;
  std::map<std::string, CameraAgreement> agreement_;
  /// Per camera the merger knows: when its last frame refused before merging arrived, and why.
  std::map<std::string, std::pair<std::int64_t, std::string>> refused_;
  std::int64_t last_check_ = 0;  ///< utime of the newest agreement check
};

}  // namespace depowder::perception
