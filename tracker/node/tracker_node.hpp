// depowder-tracker's logic, without the bus: options from the cell YAML, and a TrackerNode
// that turns each POINTS message into one PART_POSE per part (with the frame's utime).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "depowder/clock.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/tracker/multi_tracker.hpp"
#include "tracker_state.hpp"

namespace depowder::tracker {

struct TrackerNodeOptions {
  TrackerConfig tracker;                ///< eta1 and the Eq. 2 settings come from the cell's progress section
  bool cull_with_cameras = true;        ///< tracker.viewpoints = the cell cameras' positions (back-face culling)
  int threads = 0;                      ///< worker threads; 0: one per part, bounded by the cores
  double template_leaf = 0.005;         ///< m; the published template is thinned to this voxel (0: every sample)
  double template_resolution = 0.0005;  ///< m per count of part_pose_t.template_xyz
  double heartbeat_period = 0.5;        ///< s
  std::string state_file;               ///< last poses kept here; a restart resumes from them ("" = none)
  double state_period = 0.2;            ///< s between writes of state_file
};

/// Reads the `tracker` section of a cell (keys mirror the fields; unknown keys and out-of-range
/// values throw node::ConfigError naming the file and key). eta1 and the progress estimator
/// settings are the progress section's, so the tracker's Alg. 1 line 11 runs the same Eq. 2
/// as depowder-progress.
TrackerNodeOptions readTrackerOptions(const node::CellConfig& cell);

class TrackerNode {
 public:
  /// Loads each part's mesh (throws MeshError naming the file, std::invalid_argument naming the
  /// part for a mesh with no triangles). A part named in `resume` starts from that pose (the
  /// last one a previous run published) instead of the cell's initial pose.
  TrackerNode(const node::CellConfig& cell, const TrackerNodeOptions& options,
              const std::map<std::string, SavedPose>& resume = {});

  /// One POINTS message, arrived at `arrival` (us on a clock that only moves forward:
  /// node::steadyUtime; a log's event time on replay): one part_pose_t per part, in the cell's part
  /// order. A message that does not decode gives every part its last pose with the reason (never
  /// throws). Refused (no PART_POSE, the reason in stats().last_problem): one stamped outside 0 to
  /// 2^53 us; one not newer than the frame tracked last but by less than kClockJumpBack (reordered,
  /// or a second camera proxy publishing); one that runs more than kClockJumpBack ahead of it and
  /// the time since, unless the frame refused before it was so too and this one runs with it (a
  /// bad stamp; the clock jumped forward: depowder/clock.hpp). One further back than
  /// kClockJumpBack is the clock going back: tracked. Both clock changes count in
  /// stats().clock_restarts.
  std::vector<part_pose_t> onPoints(const point_cloud_t& msg, std::int64_t arrival);

  struct Stats {
    std::int64_t frames = 0;          ///< POINTS messages handled
    std::int64_t invalid_frames = 0;  ///< of them undecodable, empty or with NaN
    std::int64_t refused_frames = 0;  ///< of them not tracked: stamped out of range or out of order
    std::int64_t clock_restarts = 0;  ///< times POINTS' clock went back or jumped forward
    double max_gap_periods = 0;       ///< the longest time between two frames tracked, in camera frame periods
    double frame_ms_p50 = 0;          ///< wall time of onPoints over the last 100 frames
    double frame_ms_p90 = 0;
    double frame_ms_max = 0;
    std::string last_problem;  ///< the last non-tracking reason ("part: reason"), "" if all track
  };
  const Stats& stats() const { return stats_; }
  /// Each part's result for the last POINTS message that decoded (empty before the first).
  const std::vector<TrackResult>& lastResults() const { return last_results_; }
  std::vector<std::string> partNames() const;
  const MultiTracker& trackers() const { return *trackers_; }
  const char* method() const { return toString(options_.tracker.method); }
  /// The last pose published for every part past Phase 1, for saveTrackerState.
  const std::map<std::string, SavedPose>& lastPoses() const { return last_poses_; }

 private:
  /// Why a frame stamped `utime` is not tracked ("" when it is; then it is the newest).
  std::string refusedStamp(std::int64_t utime, std::int64_t arrival);
  part_pose_t toMessage(std::int64_t utime, std::size_t part, const TrackResult& r);

  TrackerNodeOptions options_;
  std::unique_ptr<MultiTracker> trackers_;
  std::vector<int> published_version_;                           ///< template version last encoded, per part
  std::vector<std::vector<std::vector<std::int16_t>>> encoded_;  ///< its quantised points
  std::deque<double> recent_ms_;
  std::vector<TrackResult> last_results_;
  Stats stats_;
  std::int64_t newest_utime_ = -1;   ///< of the newest frame tracked (-1: none yet)
  std::int64_t newest_arrival_ = 0;  ///< when it arrived
  AheadWatch ahead_;                 ///< the last frame, if it was refused as far ahead
  std::int64_t tracked_utime_ = -1;  ///< of the last frame the parts tracked (it decoded)
  double frame_rate_ = 0;            ///< Hz, the cell's fastest camera: the period of POINTS
  std::map<std::string, SavedPose> last_poses_;
  std::map<std::string, Point> cameras_;  ///< name -> position (cell), for per-frame culling
  std::set<std::string> camera_names_;    ///< the cell's cameras, for a frame that lacks some
};

}  // namespace depowder::tracker
