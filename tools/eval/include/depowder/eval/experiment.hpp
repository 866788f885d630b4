// The paper's experiments (Sec. V) on the simulator, in process and deterministic for a seed:
//   static - Table I: a still part at a set visibility, the nozzle circling it, mean errors;
//   speed  - Fig. 10: linear actuator / turntable at increasing speed, highest speed tracked.
// Every method sees the same frames: a trial renders once and tracks with each method.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/eval/json.hpp"
#include "depowder/eval/scene.hpp"
#include "depowder/sim/script.hpp"
#include "depowder/tracker/config.hpp"
#include "depowder/tracker/part_tracker.hpp"

namespace depowder::eval {

/// Interruption and progress: `stop` is polled every frame (a trial cut short is dropped, the
/// finished ones are kept); `progress` is told the work done so far, in the experiment's units.
/// One tracked frame of one method (--trace): the estimate against the truth.
struct TraceRow {
  std::string experiment, part, method;
  int trial = 0, frame = 0;
  Pose T_true = Pose::Identity();
  Pose T_start = Pose::Identity();               ///< the part's true pose at the trial's start
  double eta_true = 0;                           ///< Eq. 2 on the simulator's true powder surface
  const tracker::TrackResult* result = nullptr;  ///< the frame's (never null in a trace)
};

struct RunControl {
  std::function<bool()> stop;
  std::function<void(double done, double total, const std::string& what)> progress;
  std::function<void(const TraceRow&)> trace;  ///< every tracked frame, if set
  bool stopped() const { return stop && stop(); }
  void tell(double done, double total, const std::string& what) const {
    if (progress) progress(done, total, what);
  }
  void record(const TraceRow& row) const {
    if (trace) trace(row);
  }
};

/// The CSV header of --trace and one row of it. The error is the estimate in the true part
/// frame (T_true^-1 result->T_cell_part): its rotation vector (deg) and translation (mm) along the
/// part's own axes, so a spin about the part's axis or a roll shows as such.
std::string traceHeader();
std::string traceLine(const TraceRow& row);

struct StaticOptions {
  std::vector<double> visibilities{0.2, 0.4, 0.6, 0.8, 1.0};  ///< eta set by World::digToVisibility
  int trials = 5;             ///< per part and visibility, each a seeded yaw, offset, noise and initial error
  double duration = 2.5;      ///< s of frames per trial (at EvalCell::fps)
  double init_trans = 0.005;  ///< m, largest error of the tracker's initial pose (uniform in [0, this])
  double init_rot_deg = 3.0;  ///< deg, largest initial rotation error (random axis, uniform angle)
  double max_offset = 0.02;   ///< m, the part's centre is placed uniformly within this of the box centre
  double bottom_z = 0.03;     ///< m, the part's bottom above the box floor
  bool nozzle = true;         ///< false: no nozzle in the cell (ablation: what its interference costs)
  bool self_filter = false;   ///< the camera proxy removes the nozzle's points, as in the cell (its occlusion stays)
  double nozzle_standoff = 0.03;  ///< m from the part's bounding box to the nozzle axis (x and y semi-axes)
  double nozzle_above = 0.01;     ///< m, nozzle tip above the part's top
  double nozzle_period = 2.0;     ///< s per revolution around the part
  double nozzle_tilt_deg = 15;    ///< deg, spray axis leaning toward the part (body leaning out)
  std::uint32_t seed = 1;
};

/// One row of Table I: a part, a method, a visibility; figures are means over the trials'
/// frames (every frame counts, whatever its status: a lost frame reports the kept pose).
struct StaticRow {
  std::string part, method;
  double visibility = 0;       ///< set eta (0..1)
  double true_eta = 0;         ///< simulator's Eq. 2 eta, mean over trials
  int trials = 0, frames = 0;  ///< trials finished; frames per trial
  double rot_err_deg = 0;      ///< mean over all frames of all trials
  double trans_err_cm = 0;
  double tilt_err_deg = 0;       ///< mean angle between the estimated and true part z axes: the rotation error without
                                 ///< the spin about the part's own vertical axis (what symmetric parts cannot show)
  double final_rot_err_deg = 0;  ///< mean over trials of the last frame's error
  double final_trans_err_cm = 0;
  double worst_trial_rot_err_deg = 0;  ///< the largest per-trial mean
  double worst_trial_trans_err_cm = 0;
  double init_rot_err_deg = 0;  ///< mean initial error given to the tracker
  double init_trans_err_cm = 0;
  double tracked_fraction = 0;  ///< frames with status TRACKING
  double lost_fraction = 0;     ///< frames with status LOST or WAITING (no ICP pose)
  double template_updates = 0;  ///< per trial, mean (the first derivation included)
  double template_size = 0;     ///< CAD samples in the template, mean over frames
  double track_ms = 0;          ///< wall time of track(), mean per frame (shared machine)
  std::vector<double> trial_rot_err_deg, trial_trans_err_cm;
};

struct SpeedOptions {
  std::vector<double> visibilities{0.2, 0.4, 0.6, 0.8, 1.0};
  int trials = 2;
  double linear_base = 0.01;    ///< m/s of the recorded sequence (frames are sub-sampled)
  double linear_travel = 0.08;  ///< m along cell x
  std::vector<int> linear_factors{2, 3, 4, 6, 8, 12, 16, 24, 32};  ///< speeds tried: base x factor, increasing
  double turntable_base_deg = 6;                                   ///< deg/s of the recorded sequence
  double turntable_travel_deg = 60;                                ///< deg about the part's vertical axis
  std::vector<int> turntable_factors{2, 3, 4, 6, 8, 12, 16, 24, 32};
  double success_rot_deg = 15;   ///< Table II's success: final error within 15 deg...
  double success_trans = 0.015;  ///< ... and 15 mm
  double bottom_z = 0.03;
  double dig_step = 0.01;     ///< m / (rad x 0.1 m): the trench is dug at poses this far apart along the path
  bool follow_crater = true;  ///< re-dig around the part every frame so its visibility stays as set during the motion
  std::uint32_t seed = 1;
};

/// Per speed of a list, over the trials: how often it was tracked and the mean final errors.
struct SpeedCurve {
  std::vector<double> success_rate, final_rot_err_deg, final_trans_err_cm;
};

/// One row of Fig. 10: the highest speeds a method tracked (mean over trials; a trial's
/// figure is the last speed of the increasing list still tracked, 0 if the first failed).
struct SpeedRow {
  std::string part, method;
  double visibility = 0;
  double true_eta_start = 0, true_eta_end_linear = 0, true_eta_end_turntable = 0;  ///< simulator truth
  int trials = 0;
  double max_trans_speed_cm_s = 0;
  double max_rot_speed_deg_s = 0;
  std::vector<double> trial_trans_speed_cm_s, trial_rot_speed_deg_s;
  SpeedCurve trans_curve, rot_curve;  ///< per speed of the list
  double max_trans_tried_cm_s = 0;    ///< the list's fastest
  double max_rot_tried_deg_s = 0;
};

struct MovingOptions {
  int trials = 5;               ///< per part: seeded contact points (the paper: 5)
  double min_visibility = 0.4;  ///< initial visibility, uniform in [min, max] (the paper: about 40 to 60 %)
  double max_visibility = 0.6;
  double contact_band = 0.2;          ///< the contact height is within +-half this fraction of the part's height of
                                      ///< its centre of mass's (pushed there a part slides; pushed high it tips over)
  double max_offset_fraction = 0.25;  ///< sideways offset of the push line, up to this x the part's xy diagonal
  double push_speed = 0.02;           ///< m/s of the nozzle while pushing
  bool dig_path = true;               ///< dig the powder to the visibility's level along the push path to the wall
  double dig_step = 0.01;             ///< m between the poses the path is dug at
  double max_duration = 30;           ///< s of simulated time at most per trial
  bool self_filter = false;           ///< the camera proxy removes the pushing nozzle's points, as in the cell
  /// How well the scan alone pins the part: every this many frames (0: never), a new tracker of
  /// each method, without the filter, starts at the true pose and fits that frame's scan
  /// probe_fits times; its distance from the truth then is a probe.
  int probe_every = 0;
  int probe_fits = 4;
  /// A diagnostic no cell has: before each frame, every tracker is told the part's true motion
  /// since the last frame (PartTracker::predictMotion), all of it ("full") or only its turn about
  /// the vertical and its horizontal slide ("planar": what a model of planar pushing driven by
  /// the nozzle's path could predict at best) or only the rest, its tip and its rise or sink
  /// ("tip": what a model of tipping alone could), scaled by motion_oracle_fraction (a model that
  /// predicts part of the motion). A push lost then is lost by the fits and the filter.
  /// "physics" tells the motion the world's own physics gives the tracker's last estimate over the
  /// frame (physicsMotion): the bound of a pushing model run from the estimate, with the world's
  /// exact physics and powder. "physics-scan": the same with the powder as the scans show it
  /// (powderFromScan), not the world's.
  std::string motion_oracle;          ///< "" (none), "full", "planar", "tip", "physics" or "physics-scan"
  double motion_oracle_fraction = 1;  ///< of the true turn angle and slide
  double success_rot_deg = 15;        ///< Table II: final error within 15 deg...
  double success_trans = 0.015;       ///< ... and 15 mm
  double bottom_z = 0.03;
  std::uint32_t seed = 1;
};

/// One row of Table II: a part and a method over the trials.
struct MovingRow {
  std::string part, method;
  double visibility = 0;  ///< initial true eta, mean over trials
  int trials = 0;
  double success = 0;                                    ///< rate, 0..1
  double final_rot_err_deg = 0, final_trans_err_cm = 0;  ///< means over trials
  double moved_cm = 0, turned_deg = 0;                   ///< how far the push took the part, mean
  std::vector<int> trial_success;
  std::vector<double> trial_final_rot_err_deg, trial_final_trans_err_cm, trial_visibility, trial_moved_cm,
      trial_turned_deg;
  std::vector<double> trial_tilt_deg;      ///< angle between the part's initial and final vertical axes
  std::vector<std::string> trial_outcome;  ///< how each push ended (sim::PushOutcome)
  /// The lowest true visibility (the simulator's Eq. 2 eta) of any frame of the push: near 0, the
  /// push buried the part and no scan shows where it went.
  std::vector<double> trial_min_visibility;
  /// The tracker's status at the push's last frame (tracking, degraded, lost): a failed push the
  /// tracker still calls tracking is one the cell cannot tell from a good track.
  std::vector<std::string> trial_final_status;
  std::vector<double> probe_rot_err_deg, probe_trans_err_cm;  ///< MovingOptions::probe_every (fits that ran)
  double probe_rot_mean_deg = 0, probe_rot_p90_deg = 0, probe_trans_mean_cm = 0;
};

struct MovingResult {
  std::vector<MovingRow> rows;
  bool interrupted = false;
  double eta1 = 0;  ///< the trackers' Eq. 1 eta1: the cell's tracker section's (0 unless --set changed it)
};

/// The tracker config of an experiment: cell.tracker (baseTrackerConfig() unless changed), the
/// method, and the cell's cameras as viewpoints.
tracker::TrackerConfig evalTrackerConfig(tracker::Method method, const EvalCell& cell);

struct StaticResult {
  std::vector<StaticRow> rows;
  bool interrupted = false;
  double eta1 = 0;  ///< the trackers' Eq. 1 eta1: the cell's tracker section's (0 unless --set changed it)
};
StaticResult runStatic(const EvalCell& cell, const std::vector<EvalPart>& parts,
                       const std::vector<tracker::Method>& methods, const StaticOptions& options,
                       const RunControl& control = {});

struct SpeedResult {
  std::vector<SpeedRow> rows;
  bool interrupted = false;
  double eta1 = 0;  ///< the trackers' Eq. 1 eta1: the cell's tracker section's (0 unless --set changed it)
};
SpeedResult runSpeed(const EvalCell& cell, const std::vector<EvalPart>& parts,
                     const std::vector<tracker::Method>& methods, const SpeedOptions& options,
                     const RunControl& control = {});

/// Needs the simulator's physics (built only when sim/ has it: DEPOWDER_EVAL_MOVING).
MovingResult runMoving(const EvalCell& cell, const std::vector<EvalPart>& parts,
                       const std::vector<tracker::Method>& methods, const MovingOptions& options,
                       const RunControl& control = {});
Json toJson(const MovingResult& result, const MovingOptions& options);
/// Which part of a motion MovingOptions::motion_oracle tells.
enum class MotionPart {
  kFull,     ///< all of it
  kPlanar,   ///< its turn about the vertical (turnAboutVertical) and its horizontal slide
  kTip,      ///< the rest: the rotation that follows the planar turn, and the rise or sink
  kPhysics,  ///< not the true motion: the world's physics run from the estimate (physicsMotion)
};
/// The MotionPart a motion_oracle names: "full", "planar", "tip", "physics" or "physics-scan". Throws
/// std::invalid_argument naming any other.
inline MotionPart motionPart(const std::string& name) {
  if (name == "full") return MotionPart::kFull;
  if (name == "planar") return MotionPart::kPlanar;
  if (name == "tip") return MotionPart::kTip;
  if (name == "physics" || name == "physics-scan") return MotionPart::kPhysics;
  throw std::invalid_argument("motion oracle must be full, planar, tip, physics or physics-scan, got '" + name + "'");
}
/// MovingOptions::motion_oracle's motion from pose T_a to T_b (cell frame), about the part's
/// origin: `part` of it, `fraction` of that part's turn angle and of its origin's displacement.
/// The tip applied after the planar part is the full motion.
Pose oracleMotion(const Pose& T_a, const Pose& T_b, MotionPart part, double fraction);
/// The powder as a cell sees it ("physics-scan"): each column of `powder` that holds scan points
/// takes their median height, but for the points on the nozzle (T_cell_nozzle, if given: within
/// 2.5 cm of its body's axis) and within `margin` of the part's box at T_cell_part (its own
/// surface, and the powder it touches, unknown); other columns keep what they had.
void powderFromScan(sim::PowderField& powder, const Cloud& scan, const Pose* T_cell_nozzle,
                    const Eigen::AlignedBox3d& box_part, const Pose& T_cell_part, double margin);
/// MotionPart::kPhysics: the motion (cell frame) of part 0 of `shadow`, a world built like the
/// real one, when its powder is set to `powder`, the part put at rest at `T_from` and the nozzle
/// stepped through the arm states `steps`, `dt` s each. Started at the part's true pose and state, it is the
/// world's own motion over those steps; started at an estimate, it is what a model of pushing
/// with the world's exact physics and powder would predict from there.
Pose physicsMotion(sim::World& shadow, const sim::PowderField& powder, const Pose& T_from,
                   const std::vector<sim::ArmState>& steps, double dt);

/// {"experiment": "static", "seed", "interrupted", "options", "rows": [...]} (keys of each row
/// as the issue lists them, plus the extra figures above).
Json toJson(const StaticResult& result, const StaticOptions& options);
Json toJson(const SpeedResult& result, const SpeedOptions& options);

}  // namespace depowder::eval
