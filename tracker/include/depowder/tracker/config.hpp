// The tracker's configuration: one plain struct with a default and a unit on every
// field (YAML keys in config/cell.yaml `tracker:` mirror the field names).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/progress/progress.hpp"

namespace depowder::tracker {

/// The three methods of the paper's comparison (Sec. V-A "Baseline Comparison"). They share
/// every line of the tracker except the template update policy (update_policy.hpp).
enum class Method {
  kCu,          ///< CU-ICP: template re-derived only when Eq. 1 fires (Alg. 1)
  kContinuous,  ///< Continuous ICP: template re-derived every frame (Strategy 2)
  kVanilla,     ///< Vanilla ICP: the whole CAD model, never updated (Strategy 1)
};

/// "cu", "continuous", "vanilla".
const char* toString(Method method);
/// The method called `name`, or nullopt.
std::optional<Method> methodFromString(const std::string& name);

/// The registration (Alg. 1, line 8). Defaults measured with depowder-bench.
struct IcpConfig {
  int max_iterations = 30;                 ///< per frame (the authors: 30)
  double max_correspondence_distance = 0;  ///< m; 0 = the part's xi (as the authors)
  double convergence_translation = 5e-4;   ///< m: stop when an update moves less than this...
  double convergence_rotation = 5e-3;      ///< rad: ...and rotates less than this (0.29 deg)
  double kernel_scale =
      0.002;                  ///< m, least Geman-McClure scale (it adapts: 3 robust sigmas of the residuals); 0 = none
  double motion_prior = 0.3;  ///< prior towards the previous pose along weak directions, in matches' worth;
                              ///< it holds what the scan cannot see (a tube's spin); 0 = none (one-off use)
  double weak_direction = 0.2;  ///< a motion constrained by less than this fraction of the matches is weak
  double hold_chi2 = 25;        ///< along the weak directions, a move from the previous pose that lowers the weighted
                                ///< squared residuals by less than this many variances is noise: kept at the previous
                                ///< pose, so a still tube does not random-walk about its axis; 0 = never hold
  double max_step_rotation = 0.1;  ///< rad per iteration (translation steps: half the correspondence distance)
  int min_correspondences = 12;    ///< fewer: the fit is refused (6 unknowns; keep well above)
  double point_weight = 0;         ///< weight of a match's offset along the tangent plane (1: point-to-point)
};

/// When a fit is believed (TrackResult::status). The same rule for all three methods.
struct StatusConfig {
  double tracking_min_inlier_ratio = 0.5;  ///< below: DEGRADED (pose kept but doubtful)
  double tracking_max_rms = 0.003;         ///< m RMS point-to-plane residual; above: DEGRADED
  double lost_min_inlier_ratio = 0.3;      ///< below: LOST (pose refused, last good pose kept)
  double lost_max_rms = 0.006;             ///< m; above: LOST
};

/// Not in the paper: an alternative to IcpConfig's motion prior and hold for parts that move
/// (tracker/README.md, "The filter"). The pose carries an information matrix from frame to frame
/// (a Kalman filter's, in information form): it loses the process noise below each frame and
/// gains each fit's. ICP is pulled towards the last pose by that information, so what the scans
/// have shown over many frames holds, and a direction they constrain well follows the scan at
/// once. The process noise is set per cell-frame direction: a part in powder slides and turns
/// about the vertical, it seldom tips, so a roll that the scan cannot tell from a slide is
/// resolved as the slide.
struct FilterConfig {
  double data_inflation = 0;  ///< a fit counts this many times less than its residuals claim (they are not
                              ///< independent); 0 = off: the motion prior and the hold instead
  double q_yaw_deg = 0.2;     ///< deg per frame: process noise of a turn about the vertical
  double q_tilt_deg = 0.01;   ///< deg per frame: of a tip about a horizontal axis
  double q_xy = 0.001;        ///< m per frame: of a horizontal slide
  double q_z = 0.0002;        ///< m per frame: of a rise or a sink
  double initial_deg = 0.5;   ///< uncertainty of the initial pose (and of a refit's), deg...
  double initial_m = 0.001;   ///< ...and m
};

struct TrackerConfig {
  Method method = Method::kCu;
  double delta1_deg = 30;         ///< deg, Eq. 1 rotation threshold (paper Sec. V-A: 30 deg)
  double delta2 = 0.05;           ///< m, Eq. 1 translation threshold (paper: 5 cm)
  double delta3 = 0.15;           ///< Eq. 1 progress threshold, fraction (paper: 15 %)
  double eta1 = 0.30;             ///< Phase 1 ends above this progress: no ICP at or below (Sec. III-B)
  double cad_spacing = 0.0025;    ///< m, spacing of P_cad's surface samples (template resolution)
  double icp_leaf = 0.005;        ///< m, the template is thinned to one point per voxel for ICP (scan: 5 mm voxels)
  double crop_margin = 0.03;      ///< m, the scan is cropped to the CAD bounding box at the predicted pose + this
  int min_scan_points = 30;       ///< fewer points in the crop: frame refused, last good pose kept
  std::vector<Point> viewpoints;  ///< camera positions, cell frame, m (the node takes the cell's cameras); ICP
                                  ///< skips template points facing away from all of them. Empty: no culling
  double refit_margin = 0.02;     ///< the refit (sight.hpp) replaces the pose when its sight score beats the tracked
                                  ///< pose's by this fraction of P_cad's icp_leaf samples; 0 = never refit
  double refit_min_rotation_deg = 10;  ///< deg; a refit that turns the pose less (and moves it less than xi) is not taken
  double refit_min_eta = 0.85;    ///< the refit runs only above this progress: with more of the part under powder, a
                                  ///< whole-model score prefers poses that lift the buried part onto the powder
  IcpConfig icp;
  FilterConfig filter;
  StatusConfig status;
  progress::ProgressConfig progress;  ///< Eq. 2 settings for the update rule (Alg. 1, line 11)
};

/// Empty if `config` is usable, otherwise what is wrong (names the field).
std::string validate(const TrackerConfig& config);

/// Sets the numeric field `key`, named as in the YAML ("delta2", "icp.motion_prior", ...), to
/// `value` (the --set of depowder-bench and depowder-eval). Throws std::invalid_argument
/// naming the known keys, or what validate() finds wrong with the result.
void setField(TrackerConfig& config, const std::string& key, double value);

}  // namespace depowder::tracker
