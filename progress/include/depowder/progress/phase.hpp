// What turns one part's per-frame Eq. 2 values into the progress the planner acts on:
// an eta filter (one noisy frame must not move eta) and the phase state machine
// (paper Sec. III-B: 1 vacuum at the initial pose, 2 vacuum at the tracked pose,
// 3 air blast, then done).
//
// The filter, measured by depowder-progress-bench (sequence section): the authors'
// running maximum latches every upward spike until the truth catches up, and after
// a part topples (its H_max / H_min change, Eq. 2's footnote: eta always follows the
// current pose) it stays at the old, higher value for good. The default is a median
// over the last `window` frames that is cleared when the pose jumps: one or two bad
// frames in five cannot move it, it follows a topple within `window` frames, and it
// follows powder that slides back, which a monotone filter cannot. A jump is taken only
// when the next frame confirms it (its pose also far from the old one and near the
// jumped pose); until then that frame's eta is not used, so one glitched PART_POSE cannot
// clear the filter and put its own eta through: a topple is followed one frame later.
#pragma once

#include <cstdint>
#include <deque>
#include <string>

#include "depowder/geometry.hpp"

namespace depowder::progress {

enum class EtaFilterMode {
  kMedian,           ///< median of the last `window` values, cleared on a confirmed pose jump (default)
  kRunningMax,       ///< the authors': max of all values so far
  kRunningMaxReset,  ///< max since the last confirmed pose jump
  kNone,             ///< the raw value
};
const char* toString(EtaFilterMode m);
/// "median", "running_max", "running_max_reset", "none"; false if `name` is none of them.
bool parseEtaFilterMode(const std::string& name, EtaFilterMode& mode);

struct EtaFilterConfig {
  EtaFilterMode mode = EtaFilterMode::kMedian;
  int window = 5;                   ///< frames in the median
  double reset_rotation_deg = 20;   ///< deg of rotation since the last reset that is a pose jump
  double reset_translation = 0.03;  ///< m of translation since the last reset that is a pose jump
};

class EtaFilter {
 public:
  explicit EtaFilter(EtaFilterConfig config = {}) : config_(config) {}

  /// Adds this frame's Eq. 2 value (status kOk only) computed at pose T_cell_part; returns the
  /// filtered eta. Non-finite eta or pose: ignored, the previous value is returned. kMedian and
  /// kRunningMaxReset: a pose jump from the last reset's pose is held (the previous value is
  /// returned) until the next frame confirms it (far from that pose too, and near the jumped one);
  /// then the filter restarts from both frames' values.
  double update(double eta_raw, const Pose& T_cell_part);
  double value() const { return value_; }
  bool empty() const { return !has_value_; }
  /// Times the filter was cleared by a confirmed pose jump.
  int resets() const { return resets_; }
  void reset();

 private:
  /// More than reset_rotation_deg or reset_translation apart.
  bool farFrom(const Pose& a, const Pose& b) const;
  void add(double eta_raw);

  EtaFilterConfig config_;
  std::deque<double> window_;
  Pose reference_ = Pose::Identity();  ///< pose at the last reset
  double value_ = 0;
  bool has_value_ = false;
  int resets_ = 0;
  bool jump_pending_ = false;          ///< the last frame jumped from reference_, not confirmed yet
  Pose jump_pose_ = Pose::Identity();  ///< its pose
  double jump_eta_ = 0;                ///< and its eta
};

/// Values of progress_t.PHASE_*.
enum class Phase : std::int8_t { kVacuumBuried = 1, kVacuumTracked = 2, kAirBlast = 3, kDone = 4 };
const char* toString(Phase p);

struct PhaseConfig {
  double eta1 = 0.30;         ///< phase 1 -> 2 (paper: 30 %)
  double eta2 = 0.85;         ///< phase 2 -> 3 (paper: 85 %)
  double hysteresis = 0.03;   ///< phase 3 falls back to 2 only below eta2 - hysteresis
  double done_eta = 0.90;     ///< the eta the air-blast pass must confirm ("the target", Sec. IV-C footnote)
  int done_frames = 10;       ///< consecutive frames at or above done_eta, after blast_min_s of blasting
  double blast_min_s = 5.0;   ///< s of air blast (from the first air-blast plan) before done can be declared
  bool require_blast = true;  ///< done needs an air-blast plan for the part; false: time in phase 3 counts
};

/// One part's phase. Forward by thresholds on the filtered eta; 3 -> 2 if eta drops (powder slid
/// back, the part fell into powder); never back to 1, because phase 1 assumes the part still sits
/// at its printed pose (paper footnote), which is not known any more once it was uncovered.
/// Done: in phase 3, the air blast has run blast_min_s, and eta >= done_eta for done_frames frames.
class PhaseMachine {
 public:
  explicit PhaseMachine(PhaseConfig config = {}) : config_(config) {}

  /// One frame's filtered eta at `utime` (us). Returns the phase after it.
  Phase update(double eta, std::int64_t utime);
  /// The planner sent an air-blast plan for this part (NOZZLE_PLAN phase 3) at `utime` (us).
  void airBlastStarted(std::int64_t utime);
  Phase phase() const { return phase_; }
  void reset() { *this = PhaseMachine(config_); }

 private:
  PhaseConfig config_;
  Phase phase_ = Phase::kVacuumBuried;
  std::int64_t blast_utime_ = -1;  ///< first air-blast plan (or phase-3 entry) since phase 3 began, moved on by gaps
  std::int64_t last_utime_ = -1;   ///< the frame before
  int frames_at_target_ = 0;
};

}  // namespace depowder::progress
