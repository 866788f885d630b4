// ICP of the part's template (CAD points with outward normals, part frame) onto a scan (cell
// frame, with normals oriented towards the cameras). This is Alg. 1, line 8: ICP(P_tmpl, P_i).
//
// Both ways are matched: each template point to its nearest scan point, and each scan point to
// its nearest template point, both within the correspondence distance and only where the two
// normals agree (a wall's point never pairs with the powder beside it or with the other face of
// a thin wall). Each scan point lies on the part or it does not; matched to the template, it
// pulls the template only across the surface, so the template's own edges (where the part
// enters the powder) do not drag it. A prior from the last frames (PosePrior) holds what the
// scan cannot see, such as a tube's spin.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/tracker/config.hpp"
#include "depowder/tracker/scan_index.hpp"

namespace depowder::tracker {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

enum class RegistrationStatus {
  kConverged,              ///< the last update was below the convergence thresholds
  kMaxIterations,          ///< stopped at max_iterations (the pose is still the best estimate)
  kTooFewCorrespondences,  ///< fewer than min_correspondences: the guess is returned unchanged
  kDegenerate,             ///< the normal equations could not be solved: the guess is returned
  kInvalidInput,           ///< empty source, size mismatch, non-finite guess or bad config
};
const char* toString(RegistrationStatus status);

/// A point cloud with unit normals and an index over its points (the same cloud).
struct Surface {
  const Cloud& points;
  const Cloud& normals;
  const ScanIndex& index;
  const std::vector<std::uint8_t>* pulls = nullptr;  ///< scan only: points matched to the template too (null: all)
};

/// What earlier frames say about the pose (the tracker's filter). Deviations of a pose T from
/// T_cell_part are the rotation vector of R R_prior^T (cell axes, about the part's origin) and
/// the translation t - t_prior (cell axes, m): the coordinates of RegistrationResult::information.
struct PosePrior {
  Pose T_cell_part = Pose::Identity();
  Matrix6d information = Matrix6d::Zero();  ///< 1/rad^2, 1/m^2
  double inflation = 1;                     ///< the fit's information counts this many times less (its
                                            ///< residuals are not independent: neighbouring voxels share noise)
};

/// A pair: template point `i` and scan point `j`, found from the template's side or the scan's.
struct Match {
  int i, j;
  bool from_template;
};

/// The matches a registration searched at its guess (its first round). A second registration of
/// the same two surfaces from the same guess, such as the disagreement check's fit without the
/// filter, starts from them: one search fewer, the same result. Valid for one pair of surfaces
/// (one frame): the guess and distance are checked, the surfaces are not.
struct FirstMatches {
  bool filled = false;
  Pose T = Pose::Identity();
  double max_distance = 0;
  std::vector<Match> matches;
};

/// The deviation of T from T_prior in PosePrior's coordinates (rad, m).
Vector6d deviation(const Pose& T, const Pose& T_prior);
/// T moved by a deviation in PosePrior's coordinates: deviation(moved(T, d), T) = d.
Pose moved(const Pose& T, const Vector6d& d);

struct RegistrationResult {
  RegistrationStatus status = RegistrationStatus::kInvalidInput;
  std::string reason;                       ///< why, when not converged
  Pose T_target_source = Pose::Identity();  ///< always a valid rigid transform
  int iterations = 0;                       ///< Gauss-Newton steps
  int associations = 0;                     ///< of them, after searching the matches again
  int correspondences = 0;                  ///< template points matched in the last round
  int scan_matches = 0;                     ///< scan points matched to the template in the last round
  double inlier_ratio = 0;                  ///< correspondences / template points
  double rms = 0;                           ///< m, RMS point-to-plane residual of the template's matches
  /// What the last round's matches say about the pose: their Gauss-Newton matrix over the
  /// residual variance, in PosePrior's coordinates. The tracker's filter adds it up over frames.
  Matrix6d information = Matrix6d::Zero();
  bool ok() const { return status == RegistrationStatus::kConverged || status == RegistrationStatus::kMaxIterations; }
};

/// Registers `model` (the template: part frame, outward unit normals, its index in the part
/// frame) onto `scan` (cell frame, normals towards the cameras), starting at `guess`.
/// Association within `max_distance` (m) both ways, between points whose normals are within
/// acos(config.normal_min_cos); residual: the distance to the template point's tangent plane,
/// plus, for the template's matches, config.tangent_weight of the offset along it; weights by a
/// Geman-McClure kernel whose scale adapts to the residuals (3 robust sigmas, never below
/// config.kernel_scale). Gauss-Newton on the pose, with `prior` (if given) added to the cost.
/// config.max_correspondence_distance is not read here.
/// With `first`, the first round's matches are taken from it when it holds those of the same
/// surfaces, guess and distance, and stored in it otherwise.
RegistrationResult registerSurfaces(const Surface& model, const Surface& scan, const Pose& guess, double max_distance,
                                    const IcpConfig& config, const PosePrior* prior = nullptr,
                                    FirstMatches* first = nullptr);

/// Same, indexing both clouds itself (tests, one-off registrations).
RegistrationResult registerSurfaces(const Cloud& model, const Cloud& model_normals, const Cloud& scan,
                                    const Cloud& scan_normals, const Pose& guess, double max_distance,
                                    const IcpConfig& config);

/// Unit normals of the indexed points: the least-variance axis of their neighbours within
/// `radius` (m), turned towards the viewpoint it faces most squarely (the camera that saw it);
/// without viewpoints, towards +z. A point with fewer than 4 neighbours gets a zero normal,
/// which matches nothing; so does a point i with wanted[i] == 0 (if `wanted` is given: the
/// tracker asks only for the points near the template).
Cloud scanNormals(const ScanIndex& index, const std::vector<Point>& viewpoints, double radius,
                  const std::vector<std::uint8_t>& wanted = {});

/// Nearest rotation to `R` (SVD), so a pose built from it is orthonormal to machine precision.
Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& R);

}  // namespace depowder::tracker
