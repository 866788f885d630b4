#include "depowder/tracker/registration.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "format.hpp"

namespace depowder::tracker {

const char* toString(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kConverged:
      return "converged";
    case RegistrationStatus::kMaxIterations:
      return "max_iterations";
    case RegistrationStatus::kTooFewCorrespondences:
      return "too_few_correspondences";
    case RegistrationStatus::kDegenerate:
      return "degenerate";
    case RegistrationStatus::kInvalidInput:
      return "invalid_input";
  }
  return "?";
}

Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& R) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// The normal equations of one association round (KISS-ICP's BuildLinearSystem).
struct LinearSystem {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  int matches = 0;
  double sum_w = 0;    ///< robust weights: the matches' worth
  double sum_r2 = 0;   ///< unweighted, for the RMS
  double sum_wr2 = 0;  ///< weighted, for the noise level of the hold test
};

// Geman-McClure weight of a residual r (m) with scale s2 = scale^2; 1 without a kernel.
double robustWeight(double r, double s2) {
  if (s2 <= 0) return 1.0;
  const double k = s2 / (s2 + r * r);
  return k * k;
}

// Data association + linearisation at T_target_source. The residual of a match (p, n) <-> q is
// the distance of q, taken into the source frame, to the tangent plane of p:
//   r = n . (T^-1 q - p).
// The update perturbs the inverse pose, T^-1 <- exp(delta) T^-1 with delta = (omega, v), so
//   dr/domega = (T^-1 q) x n,  dr/dv = n;
// the CAD normals stay fixed in the part frame and Gauss-Newton is exact for this cost.
LinearSystem buildLinearSystem(const Cloud& source, const Cloud& normals, const ScanIndex& target, const Pose& T,
                               double max_distance, double s2, double point_weight, std::vector<double>& abs_r) {
  LinearSystem sys;
  abs_r.clear();
  const Pose T_inv = T.inverse(Eigen::Isometry);
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  const Eigen::Matrix3d Ri = T_inv.linear();
  const Eigen::Vector3d ti = T_inv.translation();
  Vector6d J;
  for (std::size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector3d p_target = R * source[i] + t;
    const ScanIndex::Hit hit = target.nearest(p_target, max_distance);
    if (!hit.found()) continue;
    const Eigen::Vector3d q = Ri * target.point(hit.index) + ti;  // scan point in the source frame
    const Eigen::Vector3d& n = normals[i];
    const double r = n.dot(q - source[i]);
    J.head<3>() = q.cross(n);
    J.tail<3>() = n;
    const double w = robustWeight(r, s2);
    sys.H.selfadjointView<Eigen::Upper>().rankUpdate(J, w);
    sys.g.noalias() += (w * r) * J;
    if (point_weight > 0) {
      // The offset along the tangent plane too, point_weight of a normal residual's worth
      // (1: point-to-point, the authors' metric).
      const Eigen::Vector3d d = q - source[i];
      const Eigen::Vector3d a = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      const Eigen::Vector3d t1 = n.cross(a).normalized();
      const Eigen::Vector3d t2 = n.cross(t1);
      for (const Eigen::Vector3d& tangent : {t1, t2}) {
        const double rt = tangent.dot(d);
        J.head<3>() = q.cross(tangent);
        J.tail<3>() = tangent;
        const double wt = point_weight * robustWeight(rt, s2);
        sys.H.selfadjointView<Eigen::Upper>().rankUpdate(J, wt);
        sys.g.noalias() += (wt * rt) * J;
      }
    }
    sys.sum_r2 += r * r;
    sys.sum_wr2 += w * r * r;
    abs_r.push_back(std::abs(r));
    sys.sum_w += w;
    ++sys.matches;
  }
  sys.H.triangularView<Eigen::StrictlyLower>() = sys.H.transpose();
  return sys;
}

// Robust-weighted residual variance of a round's matches (m^2), never below (0.1 mm)^2: a
// noise-free synthetic fit must not claim infinite information.
double residualVariance(const LinearSystem& sys) {
  return std::max(sys.sum_w > 0 ? sys.sum_wr2 / sys.sum_w : 0.0, 1e-8);
}

// exp(delta) to first order in the translation (the increments are small): rotation by
// angle-axis omega, then translation v.
Pose increment(const Vector6d& delta) {
  Pose inc = Pose::Identity();
  const Eigen::Vector3d omega = delta.head<3>();
  const double angle = omega.norm();
  if (angle > 0) inc.linear() = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  inc.translation() = delta.tail<3>();
  return inc;
}

}  // namespace

RegistrationResult registerPointToPlane(const Cloud& source, const Cloud& source_normals, const ScanIndex& target,
                                        const Pose& guess, double max_distance, const IcpConfig& config,
                                        const Matrix6d* prior) {
  RegistrationResult result;
  const bool guess_ok = guess.matrix().allFinite() && isValidPose(guess, 1e-4);
  if (guess_ok) {
    result.T_target_source = guess;
    result.T_target_source.linear() = orthonormalized(guess.linear());
  }
  auto invalid = [&](std::string why) {
    result.status = RegistrationStatus::kInvalidInput;
    result.reason = std::move(why);
    return result;
  };
  if (!guess_ok) return invalid("initial guess is not a finite rigid transform");
  if (source.empty()) return invalid("source (template) is empty");
  if (source_normals.size() != source.size())
    return invalid("source has " + std::to_string(source.size()) + " points but " +
                   std::to_string(source_normals.size()) + " normals");
  if (target.size() == 0) return invalid("target (scan) is empty");
  if (!(std::isfinite(max_distance) && max_distance > 0)) return invalid("max correspondence distance must be > 0");
  if (config.max_iterations < 1) return invalid("max_iterations must be >= 1");

  // Kernel scale: wide while the template is still far off (a part that moved 5 mm must not be
  // refused), then 3 robust sigmas of the last round's residuals, never below config.kernel_scale.
  double scale = config.kernel_scale > 0 ? std::max(config.kernel_scale, max_distance / 3) : 0.0;
  std::vector<double> abs_r;
  abs_r.reserve(source.size());
  // Characteristic length of the source: rotations about its frame's origin move points by about this.
  double length2 = 0;
  for (const Point& p : source) length2 += p.squaredNorm();
  const double length = std::max(std::sqrt(length2 / source.size()), 1e-3);
  Vector6d S;  // delta = S u
  S << Eigen::Vector3d::Constant(1.0 / length), Eigen::Vector3d::Ones();
  const Pose guess_o = result.T_target_source;  // the guess, orthonormalised
  Pose T = result.T_target_source;
  // The estimate's deviation from the guess, e = S^-1 log(T^-1 guess): zero at the start.
  auto deviation = [&](const Pose& T_now) {
    const Pose E = T_now.inverse(Eigen::Isometry) * guess_o;
    const Eigen::AngleAxisd aa(E.linear());
    Vector6d e;
    e << length * aa.angle() * aa.axis(), E.translation();
    return e;
  };
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig;                     // of the scaled H, for the weak directions
  double weak_sum_w = 0;                                           // the matches' worth when eig was computed
  Vector6d weak_e = Vector6d::Zero(), weak_gs = Vector6d::Zero();  // the deviation and the scan's gradient then
  result.status = RegistrationStatus::kMaxIterations;
  LinearSystem sys;
  for (int iteration = 1; iteration <= config.max_iterations; ++iteration) {
    // Associate and linearise at the current estimate.
    sys = buildLinearSystem(source, source_normals, target, T, max_distance, scale * scale, config.point_weight, abs_r);
    result.iterations = iteration;
    result.weak_directions = 0;
    result.correspondences = sys.matches;
    result.inlier_ratio = static_cast<double>(sys.matches) / static_cast<double>(source.size());
    result.rms = sys.matches > 0 ? std::sqrt(sys.sum_r2 / sys.matches) : 0.0;
    if (sys.matches < std::max(config.min_correspondences, 6)) {
      result.status = RegistrationStatus::kTooFewCorrespondences;
      result.reason = "only " + std::to_string(sys.matches) + " template points have a scan point within " +
                      detail::fixed(max_distance * 1000, 1) + " mm (need " +
                      std::to_string(config.min_correspondences) + ")";
      result.T_target_source = guess;
      result.T_target_source.linear() = orthonormalized(guess.linear());
      return result;
    }
    // Solve in the directions the matches constrain; then a trust region: no step may move
    // the template further than the association can follow.
    if (config.kernel_scale > 0 && !abs_r.empty()) {
      std::nth_element(abs_r.begin(), abs_r.begin() + abs_r.size() / 2, abs_r.end());
      scale = std::max(config.kernel_scale, 3 * 1.4826 * abs_r[abs_r.size() / 2]);
    }
    // Solve in scaled coordinates u (rotations times `length`: all six are displacements, and an
    // eigenvalue of the scaled H counts matched points' worth of constraint), with a motion prior
    // mu |e + u|^2 towards the guess along the weakly constrained eigen-directions only (below
    // config.weak_direction of the matches): a tube's spin or a plane's slide stays at the guess
    // instead of turning with the noise, while well-constrained directions follow the scan with
    // no lag. e is the estimate's deviation from the guess so far (Zhang et al., ICRA 2016, for
    // the degeneracy; a soft prior instead of their hard cut).
    const Matrix6d Hs = S.asDiagonal() * sys.H * S.asDiagonal();
    Vector6d gs = S.asDiagonal() * sys.g;
    Matrix6d A = Hs;
    if (prior != nullptr) {
      // The filter's information about the deviation from the guess, in the residuals' units:
      // min sum w r^2 / variance + d' P d, with d = S e.
      const double variance = residualVariance(sys);
      const Matrix6d P = variance * S.asDiagonal() * (*prior) * S.asDiagonal();
      A += P;
      gs.noalias() += P * deviation(T);
    } else if (config.motion_prior > 0 || config.hold_chi2 > 0) {
      const Vector6d e = deviation(T);
      eig.compute(Hs);
      weak_sum_w = sys.sum_w;
      weak_e = e;
      weak_gs = gs;
      const double mu = config.motion_prior * sys.sum_w;
      for (int k = 0; k < 6; ++k) {
        if (eig.eigenvalues()[k] >= config.weak_direction * sys.sum_w) continue;
        const Vector6d v = eig.eigenvectors().col(k);
        A.noalias() += mu * v * v.transpose();
        gs.noalias() += (mu * v.dot(e)) * v;
        ++result.weak_directions;
      }
    }
    A.diagonal().array() += 1e-12 * std::max(A.diagonal().maxCoeff(), 1e-300);  // numerical floor
    Vector6d delta = S.asDiagonal() * (-A.ldlt().solve(gs));
    delta /= std::max(
        {1.0, delta.tail<3>().norm() / (0.5 * max_distance), delta.head<3>().norm() / config.max_step_rotation});
    if (!delta.allFinite()) {
      result.status = RegistrationStatus::kDegenerate;
      result.reason = "the ICP normal equations are singular";
      result.T_target_source = guess;
      result.T_target_source.linear() = orthonormalized(guess.linear());
      return result;
    }
    // T^-1 <- exp(delta) T^-1, i.e. T <- T exp(delta)^-1.
    T = T * increment(delta).inverse(Eigen::Isometry);
    if (delta.tail<3>().norm() < config.convergence_translation &&
        delta.head<3>().norm() < config.convergence_rotation) {
      result.status = RegistrationStatus::kConverged;
      break;
    }
  }
  T.linear() = orthonormalized(T.linear());
  result.T_target_source = T;
  if (sys.matches > 0) result.information = sys.H / residualVariance(sys);
  // The hold: along the weak directions the scan would move the estimate (the least-squares
  // optimum there, without the prior) by no more than its noise would: the weighted squared
  // residuals would fall by less than hold_chi2 variances (about chi-square for a part that
  // stayed still). Then the estimate stays at the guess there: a still tube does not
  // random-walk about its axis, and a turning one adds up until it stands out.
  if (prior == nullptr && config.hold_chi2 > 0 && weak_sum_w > 0 && sys.sum_w > 0 && sys.sum_wr2 > 0) {
    const double variance = sys.sum_wr2 / sys.sum_w;
    double chi2 = 0;
    Vector6d weak_part = Vector6d::Zero();
    const Vector6d e = deviation(T);
    for (int k = 0; k < 6; ++k) {
      const double lambda = eig.eigenvalues()[k];
      if (lambda >= config.weak_direction * weak_sum_w) continue;
      const Vector6d v = eig.eigenvectors().col(k);
      weak_part += v.dot(e) * v;
      if (lambda <= 1e-9 * weak_sum_w) continue;  // unobservable: no evidence either way
      const double optimum = v.dot(weak_e) - v.dot(weak_gs) / lambda;
      chi2 += lambda * optimum * optimum / variance;
    }
    result.weak_motion_chi2 = chi2;
    if (chi2 < config.hold_chi2 && weak_part.squaredNorm() > 0) {
      T = guess_o * increment(S.asDiagonal() * (e - weak_part)).inverse(Eigen::Isometry);
      T.linear() = orthonormalized(T.linear());
      result.T_target_source = T;
      result.held = true;
    }
  }
  if (result.status == RegistrationStatus::kMaxIterations)
    result.reason = "stopped after " + std::to_string(config.max_iterations) + " iterations without converging";
  return result;
}

RegistrationResult registerPointToPlane(const Cloud& source, const Cloud& source_normals, const Cloud& target,
                                        const Pose& guess, double max_distance, const IcpConfig& config) {
  const ScanIndex index(target, std::isfinite(max_distance) && max_distance > 0 ? max_distance : 1.0);
  return registerPointToPlane(source, source_normals, index, guess, max_distance, config);
}

}  // namespace depowder::tracker
