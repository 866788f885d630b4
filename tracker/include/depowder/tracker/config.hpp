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

/// The registration (Alg. 1, line 8; registration.hpp). Defaults measured with depowder-eval.
struct IcpConfig {
  int max_iterations = 30;                 ///< per frame (the authors: 30)
  double max_correspondence_distance = 0;  ///< m; 0 = the part's xi (as the authors)
  double convergence_translation = 1e-4;   ///< m: stop when an update moves less than this...
  double convergence_rotation = 1e-3;      ///< rad: ...and rotates less than this (0.06 deg)
  double kernel_scale =
      0.002;  ///< m, least Geman-McClure scale (it adapts: 3 robust sigmas of the residuals); 0 = none
  double normal_min_cos = 0.7;     ///< matched points' normals must be within acos(this) (45 deg): a wall never pairs
                                   ///< with the powder beside it or with the other face of a thin wall
  double normal_radius = 0.01;     ///< m, neighbourhood of a scan point's normal (its neighbours' least-variance axis)
  double tangent_weight = 0.3;     ///< weight of a template match's offset along the tangent plane (1: point-to-point,
                                   ///< the authors' metric; 0: point-to-plane)
  double scan_weight = 1;          ///< weight of the scan -> template matches (0: template -> scan only)
  double max_step_rotation = 0.1;  ///< rad per iteration (translation steps: half the correspondence distance)
  double reassociate = 0.001;      ///< m: the matches are searched again once the template moved this far (and
                                   ///< before convergence is declared); 0 = every iteration
  int min_correspondences = 12;    ///< fewer: the fit is refused (6 unknowns; keep well above)
};

/// The template points ICP uses in a frame: those facing a camera and above the powder around
/// them (the powder contour of Eq. 2 from the last frame: a wall that a push has buried under a
/// pile of powder, or the band just under the powder line, is not matched to the powder).
struct VisibilityConfig {
  double powder_radius = 0.02;  ///< m: the powder height at a point is the median of the last frame's contour band
                                ///< points within this (2-D); 0 = no powder test
  double powder_margin = 0.0;   ///< m: points lower than that height + this are left out
  double cover = 0.003;         ///< m: an upward-facing point with a scan point 3-15 mm (this to this + 12 mm)
                                ///< straight above it is under powder and left out; 0 = no cover test
  double powder_scan_margin = 0.011;  ///< m: while the part is still, an upward-facing scan point lower than that
                                      ///< height + this is taken for powder: template points are matched to it,
                                      ///< it is not matched to the template (icp.scan_weight); 0 = every scan
                                      ///< point is. The powder round a part varies by about 1 cm (a vacuumed
                                      ///< ring beside untouched powder)
};

/// When a fit is believed (TrackResult::status). The same rule for all three methods.
struct StatusConfig {
  double tracking_min_inlier_ratio = 0.5;  ///< below: DEGRADED (pose kept but doubtful)
  double tracking_max_rms = 0.003;         ///< m RMS point-to-plane residual; above: DEGRADED
  double lost_min_inlier_ratio = 0.3;      ///< below: LOST (pose refused, last good pose kept)
  double lost_max_rms = 0.006;             ///< m; above: LOST
};

/// Not in the paper: the pose's information carried from frame to frame (a Kalman filter in
/// information form, tracker/README.md "The filter"). It loses the process noise below each frame
/// and gains each fit's; ICP is pulled towards the last pose by it, so what the scans have shown
/// over many frames holds (a tube's spin, which no single frame shows), and a direction they
/// constrain well follows the scan at once. The process noise is set per cell-frame direction: a
/// part in powder slides and turns about the vertical, it seldom tips, so a roll that the scan
/// cannot tell from a slide is resolved as the slide. A part that has not moved over the last
/// moving_frames frame periods is still: its turns' process noise shrinks by still_turn, so a still
/// tube's unseen spin does not wander with the noise; a part that moved only a little more is
/// given a little more (moving_full): a still part whose fit was shifted by the nozzle is not
/// handed a pushed part's turns.
struct FilterConfig {
  double data_inflation = 10;  ///< a fit counts this many times less than its residuals claim (neighbouring voxels
                               ///< share noise); 0 = off: every frame registered on its own from the last pose
  double q_yaw_deg = 2.0;      ///< deg per frame: process noise of a turn about the vertical (a pushed part)
  double q_tilt_deg = 0.01;    ///< deg per frame: of a tip about a horizontal axis
  double q_xy = 0.001;         ///< m per frame: of a horizontal slide
  double q_z = 0.0002;         ///< m per frame: of a rise or a sink
  double still_turn = 0.0025;  ///< a still part's turn noise: this fraction of q_yaw_deg and q_tilt_deg
  double moving_translation = 0.002;  ///< m: a part that moved more than this over the last moving_frames periods...
  double moving_rotation_deg = 2;     ///< ...or turned more than this (deg) is moving
  int moving_frames = 10;             ///< frame periods (1/3 s at 30 fps), however many were tracked
  double fall_sink = 0.003;  ///< m: a part whose origin sank more than this over the last moving_frames periods is
                             ///< falling (it topples)...
  double fall_tilt_deg = 0;  ///< ...and its tip noise is this, deg per frame; 0 = no such gate (the default: a
                             ///< lagging estimate sinks too, tracker/README.md); a cell whose parts topple: 1
  double moving_full = 2;    ///< a moving part's turn noise opens from a still part's (at the thresholds above) to a
                             ///< pushed part's (at this many times them), in proportion; 1 = at once
  double initial_deg = 0.5;  ///< uncertainty of the initial pose (and of a refit's), deg...
  double initial_m = 0.001;  ///< ...and m
  /// The disagreement check: each frame (see check_every) the scan is also registered without
  /// the filter. Over its last reset_frames runs, the mean difference of the two fits is tested
  /// against both fits' uncertainties (reset_chi2) and by what it asks of the pose in the ways a pushed part
  /// moves (turns about the vertical and slides, the process noise of the periods those runs span: beyond
  /// reset_deg or reset_m). Both beyond, and the free fits matching about as many template
  /// points as the filter's (reset_inlier_margin), and the move asked explaining most of the
  /// difference (reset_unexplained): the filter held a moving part still, and starts again from its
  /// pose moved as asked. reset_frames 0 = no check.
  double reset_chi2 = 300;            ///< chi-square of the mean difference, 6 dof (frames are not independent)
  double reset_deg = 4;               ///< deg
  double reset_m = 0.002;             ///< m
  double reset_inlier_margin = 0.02;  ///< and the free fits' mean inlier ratio is at most this below the filter's
                                      ///< (they explain the scan about as well); 1 = no such test
  double reset_unexplained = 0.5;     ///< and what the move asked leaves of the mean difference has at most this
                                      ///< fraction of its chi-square (the rest is no push's motion); 1 = no such test
  int reset_frames = 8;
  /// While the part is still and the last check's two fits agreed (within reset_deg / 2 and
  /// reset_m), the check runs every check_every-th frame only; otherwise every frame. 1 = always.
  int check_every = 4;
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
  double refit_min_rotation_deg =
      10;                       ///< deg; a refit that turns the pose less (and moves it less than xi) is not taken
  double refit_min_eta = 0.85;  ///< the refit runs only above this progress: with more of the part under powder, a
                                ///< whole-model score prefers poses that lift the buried part onto the powder
  IcpConfig icp;
  VisibilityConfig visibility;
  FilterConfig filter;
  StatusConfig status;
  progress::ProgressConfig progress;  ///< Eq. 2 settings for the update rule (Alg. 1, line 11)
};

/// Empty if `config` is usable, otherwise what is wrong (names the field).
std::string validate(const TrackerConfig& config);

/// Sets the numeric field `key`, named as in the YAML ("delta2", "icp.tangent_weight", ...), to
/// `value` (the --set of depowder-bench and depowder-eval). Throws std::invalid_argument, leaving
/// `config` as it was, naming the known keys, a value that is not a number (or not a whole one for
/// a count), or what validate() finds wrong with the result.
void setField(TrackerConfig& config, const std::string& key, double value);

}  // namespace depowder::tracker
