// Point-to-plane ICP of an oriented source (CAD template points with their normals)
// onto a target scan, with a robust kernel and nearest-neighbour association in a
// ScanIndex built once per frame. This is Alg. 1, line 8: ICP(P_tmpl, P_i).
#pragma once

#include <string>

#include "depowder/geometry.hpp"
#include "depowder/tracker/config.hpp"
#include "depowder/tracker/scan_index.hpp"

namespace depowder::tracker {

enum class RegistrationStatus {
  kConverged,              ///< the last update was below the convergence thresholds
  kMaxIterations,          ///< stopped at max_iterations (the pose is still the best estimate)
  kTooFewCorrespondences,  ///< fewer than min_correspondences: the guess is returned unchanged
  kDegenerate,             ///< the normal equations could not be solved: the guess is returned
  kInvalidInput,           ///< empty source, size mismatch, non-finite guess or bad config
};
const char* toString(RegistrationStatus status);

struct RegistrationResult {
  RegistrationStatus status = RegistrationStatus::kInvalidInput;
  std::string reason;                       ///< why, when not converged
  Pose T_target_source = Pose::Identity();  ///< always a valid rigid transform
  int iterations = 0;                       ///< association + solve rounds
  int correspondences = 0;                  ///< source points matched in the last round
  double inlier_ratio = 0;                  ///< correspondences / source points
  int weak_directions = 0;                  ///< of 6, held by the motion prior in the last round
  double rms = 0;                           ///< m, RMS point-to-plane residual of the last round's matches
  double weak_motion_chi2 = 0;              ///< the move along the weak directions over the fit's noise (see hold_chi2)
  bool held = false;                        ///< the weak directions were kept at the guess (config.hold_chi2)
  /// What the last round's matches say about the pose: their Gauss-Newton matrix over the
  /// residual variance (1/rad^2, 1/m^2), in the update's coordinates (rotation vector, then
  /// translation, of the source frame). The filter (FilterConfig) adds it up over frames.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  bool ok() const { return status == RegistrationStatus::kConverged || status == RegistrationStatus::kMaxIterations; }
};

/// Registers `source` (points and unit normals, source frame) onto the scan in `target`.
/// Association: each source point, moved by the current estimate, takes its nearest target
/// point within `max_distance` (m; the index's cell should be about that). Residual: distance
/// of that target point to the source point's tangent plane, weighted by a Geman-McClure
/// kernel whose scale adapts to the residuals (3 robust sigmas, never below
/// config.kernel_scale). Gauss-Newton on SE(3), starting at `guess`, with a motion prior
/// towards the guess worth config.motion_prior of the matches along the directions the matches
/// barely constrain (below config.weak_direction of them; motion_prior 0 for a one-off
/// registration). config.point_weight > 0 adds the match's offset along the tangent plane
/// (1: point-to-point).
/// config.max_correspondence_distance is not read here.
///
/// `prior`, if given, replaces the motion prior and the hold: the information (as
/// RegistrationResult::information) about the pose's deviation from `guess`; the estimate then
/// minimises the residuals over their variance plus that deviation's squared norm in it.
RegistrationResult registerPointToPlane(const Cloud& source, const Cloud& source_normals, const ScanIndex& target,
                                        const Pose& guess, double max_distance, const IcpConfig& config,
                                        const Eigen::Matrix<double, 6, 6>* prior = nullptr);

/// Same, indexing `target` itself (tests, one-off registrations).
RegistrationResult registerPointToPlane(const Cloud& source, const Cloud& source_normals, const Cloud& target,
                                        const Pose& guess, double max_distance, const IcpConfig& config);

/// Nearest rotation to `R` (SVD), so a pose built from it is orthonormal to machine precision.
Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& R);

}  // namespace depowder::tracker
