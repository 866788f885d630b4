// One part's tracker state and its per-frame step: Alg. 1 (CU-ICP) and its two
// baselines, which differ only in the template update policy (update_policy.hpp).
#pragma once

#include <cstdint>
#include <deque>
#include <string>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/progress/progress.hpp"
#include "depowder/tracker/config.hpp"
#include "depowder/tracker/registration.hpp"
#include "depowder/tracker/sight.hpp"
#include "depowder/tracker/template.hpp"
#include "depowder/tracker/update_policy.hpp"

namespace depowder::tracker {

/// Mirrors part_pose_t's status constants.
enum class TrackStatus {
  kWaiting,   ///< Phase 1 (eta <= eta1): no ICP, the initial pose is reported
  kTracking,  ///< ICP ran and the fit is good
  kDegraded,  ///< ICP ran, the pose was taken, but the fit is poor (see reason)
  kLost,      ///< this frame did not give a pose (bad input or failed fit): last good pose kept
};
const char* toString(TrackStatus status);

/// Wall time of each step of one track() call, milliseconds.
struct TrackTiming {
  double crop_ms = 0;      ///< crop + grid build
  double icp_ms = 0;       ///< Alg. 1, line 8
  double progress_ms = 0;  ///< line 11 (Eq. 2)
  double template_ms = 0;  ///< Alg. 2, when it ran
  double sight_ms = 0;     ///< the lines-of-sight check and the refit (not in the paper)
  double check_ms = 0;     ///< the disagreement check: the fit without the filter (not in the paper)
  double total_ms = 0;
};

struct TrackResult {
  TrackStatus status = TrackStatus::kWaiting;
  std::string reason;                   ///< why, when not kTracking; "" otherwise
  Pose T_cell_part = Pose::Identity();  ///< always valid (orthonormal, finite)
  double eta = 0;                       ///< progress used by the update rule (0..1)
  double fitness = 0;                   ///< m, RMS point-to-plane residual of the template's matches
  double inlier_ratio = 0;              ///< matched template points / template points used by ICP
  int iterations = 0;                   ///< ICP iterations this frame
  bool template_updated = false;        ///< Alg. 2 ran this frame
  bool refit = false;                   ///< the refit replaced ICP's pose (TrackerConfig::refit_margin)
  bool reset = false;                   ///< the filter started again (FilterConfig::reset_frames)
  bool checked = false;                 ///< the disagreement check ran this frame (FilterConfig::check_every)
  bool moving = false;                  ///< the filter takes the part as moving (FilterConfig::moving_translation)
  bool falling = false;                 ///< ...and as falling: its tip noise is open (FilterConfig::fall_sink)
  int template_version = 0;             ///< increments when the template changes
  std::size_t template_size = 0;        ///< CAD samples in the template
  UpdateDecision update;                ///< the policy's decision this frame (when ICP ran)
  SightCheck sight;                     ///< P_cad at the reported pose against the cameras' lines of sight
                                        ///< (when the refit ran: eta >= refit_min_eta, on a frame the
                                        ///< check was due; zeros otherwise)
  TrackTiming timing;
};

class PartTracker {
 public:
  /// Samples `mesh` (part frame, metres) every config.cad_spacing. Throws std::invalid_argument
  /// naming the part for a mesh with no triangles or no area, a bad xi, an invalid initial
  /// pose or an invalid config.
  PartTracker(std::string name, const Mesh& mesh, const Pose& T_cell_part_init, double xi,
              const TrackerConfig& config = {});

  /// One frame: `scan` is P_i in the cell frame. Never throws for bad data; the result
  /// says what happened.
  TrackResult track(const Cloud& scan);
  /// The same, with the positions of the cameras that saw this frame (cell frame) in place of
  /// config.viewpoints: with a camera silent, template points only it could see are left out.
  TrackResult track(const Cloud& scan, const std::vector<Point>& viewpoints);

  /// The part is known to move by `delta` (a rigid motion, cell frame) before the next frame:
  /// that frame's fit starts from the pose so moved, and the filter predicts it there with the
  /// information it had (before Phase 1 ends, the initial pose moves). Calls add up. Throws
  /// std::invalid_argument for a delta that is not a finite rigid motion. Nothing in the cell
  /// calls it: the evaluation's motion oracle (`depowder-eval moving --motion-oracle`) gives it
  /// the true motion, which bounds what a motion model could add to the tracker.
  void predictMotion(const Pose& delta);

  /// The next frame comes `periods` frame periods after the one given before it (more than 1:
  /// frames were dropped; the node tracks the newest POINTS only and tells it from their
  /// utimes). The filter's prediction for that frame adds as many periods of process noise
  /// (FilterConfig's q_* are per frame), as it does for the frames this tracker refused since it
  /// last fitted. Below 1 counts as 1. Throws std::invalid_argument for NaN or infinity.
  void elapse(double periods);

  /// The part had left Phase 1 before the tracker restarted (its state file): it is tracked from
  /// the next frame on, whatever eta then is; that frame derives its template at the pose.
  void resume() { started_ = true; }

  const std::string& name() const { return name_; }
  Method method() const { return config_.method; }
  double xi() const { return xi_; }
  const TrackerConfig& config() const { return config_; }
  const Pose& pose() const { return T_cell_part_; }
  bool started() const { return started_; }           ///< left Phase 1
  const SurfaceSamples& cad() const { return cad_; }  ///< P_cad, part frame
  const Indices& templateIndices() const { return template_; }
  int templateVersion() const { return template_version_; }

 private:
  double correspondenceDistance() const;
  double estimateEta(const Pose& T_cell_part, const Cloud& scan, std::string* why);
  PosePrior predicted() const;
  void setTemplate(Indices indices);
  TrackResult refuse(TrackResult r, std::string why) const;
  void placeSparse(const Pose& T_cell_part);
  int sightScore(const Pose& T_cell_part, const SightImages& images, const ScanIndex& grid);
  bool refit(const SightImages& images, const Surface& scan, double max_distance);

  std::string name_;
  TrackerConfig config_;
  double xi_;
  SurfaceSamples cad_;
  progress::EtaEstimator eta_estimator_;  ///< Eq. 2 (line 11) on P_cad thinned to icp_leaf
  Eigen::AlignedBox3d cad_box_;           ///< part frame
  Pose T_cell_part_init_;

  // Tracking state (Alg. 1).
  bool started_ = false;
  Pose T_cell_part_;                              ///< T_i
  Pose predicted_motion_ = Pose::Identity();      ///< predictMotion's, applied at the next frame
  double next_periods_ = 1;                       ///< elapse's, for the next frame
  double periods_ = 0;                            ///< frame periods since the filter last took a fit
  double eta_ = 0;                                ///< last estimate
  UpdateReference last_update_;                   ///< R_last, t_last, eta_last
  Indices template_;                              ///< P_tmpl
  Cloud icp_points_, icp_normals_;                ///< P_tmpl thinned to icp_leaf, with normals
  Cloud cad_sparse_points_, cad_sparse_normals_;  ///< P_cad thinned to icp_leaf (part frame)
  Cloud visible_points_, visible_normals_;        ///< the ICP template the cameras can see, this frame
  PowderHeights powder_;                          ///< the powder around the part, from the last Eq. 2 band
  int template_version_ = 0;
  /// The filter's information about T_i (FilterConfig; PosePrior's coordinates).
  Matrix6d information_ = Matrix6d::Zero();
  /// A pose tracked, and the frame periods since the one tracked before it.
  struct Tracked {
    Pose T_cell_part;
    double periods;
  };
  std::deque<Tracked> recent_;  ///< the poses tracked over the last moving_frames periods (the motion test)
  bool moving_ = false;
  bool falling_ = false;  ///< the origin sank more than FilterConfig::fall_sink over the last moving_frames periods
  double turn_open_ = 0;  ///< 0 (still) .. 1 (pushed): how far the turn noise is open (FilterConfig::moving_full)
  /// The fit without the filter against the filter's, the last frames: its pose less the filter's, and its
  /// inlier ratio less the filter's.
  struct Disagreement {
    Vector6d difference;
    double inlier_gain;
    double periods;  ///< frame periods since the check before it
  };
  std::deque<Disagreement> disagreements_;
  int unchecked_frames_ = 0;      ///< frames since the disagreement check last ran
  double unchecked_periods_ = 0;  ///< frame periods since the disagreement check last ran
  bool fits_disagreed_ = true;    ///< the last check's two fits differed beyond reset_deg / 2 or reset_m, or its
                                  ///< free fit was doubtful
  void resetInformation();
  void updateMotionState(double periods);  ///< moving_, falling_, turn_open_; periods since the last fit
  Vector6d processVariance() const;        ///< a pushed part's, per frame (PosePrior's coordinates)
  bool restartFilter(const RegistrationResult& filtered, const RegistrationResult& free,
                     const Matrix6d& prior_information);

  // Per-frame buffers, kept to reuse their memory.
  Cloud crop_, crop_normals_;
  std::vector<std::uint8_t> near_template_;  ///< crop points near the template (ICP's candidates)
  std::vector<std::uint8_t> scan_pulls_;     ///< crop points matched to the template too (not powder)
  Cloud sight_points_, sight_normals_;       ///< P_cad thinned to icp_leaf, cell frame at a pose
  std::vector<unsigned char> verdict_;
  Cloud refit_points_, refit_normals_;
};

}  // namespace depowder::tracker
