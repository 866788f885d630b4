// depowder-progress's logic, without the bus: options from the cell YAML, and a
// ProgressNode that pairs each POINTS frame with its PART_POSE per part, runs the
// estimator, the eta filter and the phase machine, and returns the PROGRESS messages.
//
// Pairing: the tracker publishes PART_POSE with the utime of the POINTS frame it
// used, after it has processed that frame, so a frame waits up to `pose_wait` for
// the pose with the same utime, or until a newer frame's pose comes (the tracker
// skipped it: it tracks the newest frame). Without one it uses the part's pose nearest in time
// if that is at most `pose_staleness` away from the frame; with no pose at all yet and the part
// in phase 1, the initial pose (paper Sec. III-B: phase 1 assumes the part has not
// moved); otherwise it publishes NO_POSE.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "depowder/node/cell.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/progress/phase.hpp"
#include "depowder/progress/progress.hpp"
#include "depowder/progress_t.hpp"

namespace depowder::progress {

struct ProgressNodeOptions {
  ProgressConfig estimator;
  EtaFilterConfig filter;
  PhaseConfig phase;              ///< eta1 / eta2 are copied from `estimator`
  double cad_spacing = 0.003;     ///< m between CAD surface samples (as the tracker samples P_cad)
  double pose_wait = 0.15;        ///< s a POINTS frame waits for its PART_POSE
  double pose_staleness = 0.5;    ///< s; an older pose is not used for a frame
  bool use_initial_pose = true;   ///< phase 1 with no PART_POSE yet: use the cell's initial pose
  int max_pending = 4;            ///< POINTS frames waiting for poses; older ones are processed at once
  double heartbeat_period = 0.5;  ///< s
};

/// Reads the `progress` section of a cell (keys mirror the fields; unknown keys and out-of-range
/// values throw node::ConfigError naming the file and key).
ProgressNodeOptions readProgressOptions(const node::CellConfig& cell);

class ProgressNode {
 public:
  /// Loads and samples every part's mesh (throws MeshError naming the file).
  ProgressNode(const node::CellConfig& cell, ProgressNodeOptions options);

  /// A decoded POINTS frame arrived at `now_us`, us on a clock that only moves forward (the
  /// process's node::steadyUtime): it waits for its poses by that clock.
  std::vector<progress_t> onPoints(std::int64_t utime, Cloud cloud, std::int64_t now_us);
  /// A PART_POSE arrived: frames waiting for it are processed.
  std::vector<progress_t> onPose(const part_pose_t& msg);
  /// A NOZZLE_PLAN arrived: an air-blast plan for a part starts its blast clock.
  void onPlan(const nozzle_plan_t& msg);
  /// Processes frames that waited longer than pose_wait (call it from the main loop).
  std::vector<progress_t> poll(std::int64_t now_us);

  struct Stats {
    std::int64_t frames = 0;            ///< POINTS frames received
    std::int64_t estimates = 0;         ///< (frame, part) estimates published
    std::int64_t no_pose = 0;           ///< of them NO_POSE
    std::int64_t unknown_parts = 0;     ///< PART_POSE for a part not in the cell
    std::int64_t invalid_poses = 0;     ///< PART_POSE with NaN / non-unit quaternion, or a utime outside 0 to 2^53 us
    std::int64_t duplicate_frames = 0;  ///< POINTS with the utime of a frame still pending: not used
    double last_compute_ms = 0;         ///< estimator time of the last estimate
    std::int64_t input_problems = 0;    ///< inputs not used (bad utime, unknown part, invalid pose, repeated frame)
    std::string last_problem;           ///< the last non-OK reason, for the heartbeat
  };
  const Stats& stats() const { return stats_; }
  std::vector<std::string> partNames() const;

 private:
  struct PoseRecord {
    std::int64_t utime = 0;
    Pose T_cell_part = Pose::Identity();
  };
  struct Part {
    node::PartConfig config;
    Cloud cad;                     ///< samples, part frame
    std::deque<PoseRecord> poses;  ///< recent valid poses, newest last
    EtaFilter filter;
    PhaseMachine phase;
  };
  struct Frame {
    std::int64_t utime = 0;
    std::int64_t arrived_us = 0;
    Cloud cloud;
    std::map<std::string, bool> done;  ///< per part
  };

  progress_t process(Frame& frame, Part& part, const Pose* pose, const std::string& pose_note);
  /// Processes every remaining part of `frame` with the best pose available now.
  void flush(Frame& frame, std::vector<progress_t>& out);
  /// Processes one part of `frame` with its pose nearest in time (within pose_staleness), else
  /// the initial pose in phase 1, else none (NO_POSE).
  progress_t processWithNearestPose(Frame& frame, Part& part);

  ProgressNodeOptions options_;
  std::map<std::string, Part> parts_;
  std::deque<Frame> pending_;
  Stats stats_;
};

}  // namespace depowder::progress
