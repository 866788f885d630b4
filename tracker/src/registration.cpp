#include "depowder/tracker/registration.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
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

Cloud scanNormals(const ScanIndex& index, const std::vector<Point>& viewpoints, double radius,
                  const std::vector<std::uint8_t>& wanted) {
  const Cloud& points = index.points();
  Cloud normals(points.size(), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!wanted.empty() && !wanted[i]) continue;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum2 = Eigen::Matrix3d::Zero();
    int n = 0;
    index.forEachWithin(points[i], radius, [&](int j, double) {
      sum += points[j];
      sum2.noalias() += points[j] * points[j].transpose();
      ++n;
    });
    if (n < 4) continue;
    const Eigen::Vector3d mean = sum / n;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(sum2 / n - mean * mean.transpose());
    const Eigen::Vector3d axis = eig.eigenvectors().col(0);
    // A surface faces the camera that saw it; of the two signs, the one facing a viewpoint most
    // squarely.
    double facing = viewpoints.empty() ? axis.z() : 0.0;
    for (const Point& eye : viewpoints) {
      const double c = axis.dot((eye - points[i]).normalized());
      if (std::abs(c) > std::abs(facing)) facing = c;
    }
    normals[i] = facing >= 0 ? axis : Eigen::Vector3d(-axis);
  }
  return normals;
}

namespace {

// The normal equations of one Gauss-Newton step, in the update's coordinates: a rotation vector
// about the part's origin and a translation, both in cell axes (KISS-ICP's BuildLinearSystem).
struct LinearSystem {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  int matches = 0;       ///< template points matched
  int scan_matches = 0;  ///< scan points matched
  double sum_w = 0, sum_wr2 = 0;
  double sum_r2 = 0;  ///< template matches' point-to-plane residuals, unweighted (RMS)
};

// Geman-McClure weight of a residual r (m) with scale s2 = scale^2; 1 without a kernel.
double robustWeight(double r, double s2) {
  if (s2 <= 0) return 1.0;
  const double k = s2 / (s2 + r * r);
  return k * k;
}

// Data association both ways at pose T (Alg. 1, line 8's data term): each template point's nearest
// scan point, and each scan point's nearest template point (searched in the part frame), both with
// an agreeing normal.
void associate(const Surface& model, const Surface& scan, const Pose& T, double max_distance, const IcpConfig& config,
               std::vector<Match>& matches) {
  matches.clear();
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  for (std::size_t i = 0; i < model.points.size(); ++i) {
    const Eigen::Vector3d n = R * model.normals[i];
    const ScanIndex::Hit hit = scan.index.nearest(R * model.points[i] + t, max_distance, [&](int j) {
      return n.dot(scan.normals[j]) >= config.normal_min_cos && !scan.normals[j].isZero();
    });
    if (hit.found()) matches.push_back({static_cast<int>(i), hit.index, true});
  }
  if (config.scan_weight <= 0) return;
  const Eigen::Matrix3d Rt = R.transpose();
  for (std::size_t j = 0; j < scan.points.size(); ++j) {
    if (scan.normals[j].isZero()) continue;  // no normal (or not wanted): matches nothing
    if (scan.pulls && !(*scan.pulls)[j]) continue;
    const Eigen::Vector3d ns = Rt * scan.normals[j];
    const ScanIndex::Hit hit = model.index.nearest(Rt * (scan.points[j] - t), max_distance, [&](int i) {
      return model.normals[i].dot(ns) >= config.normal_min_cos;
    });
    if (hit.found()) matches.push_back({hit.index, static_cast<int>(j), false});
  }
}

// Linearisation of the matches at pose T. A match's residual is r = dir . (p - q) for the template
// point p (cell frame) and the scan point q, with dir = p's normal n (and, for the template's
// matches, its tangents); dr/domega = (p - t) x dir, dr/dv = dir.
LinearSystem linearize(const Surface& model, const Surface& scan, const std::vector<Match>& matches, const Pose& T,
                       double s2, const IcpConfig& config, std::vector<double>& abs_r) {
  LinearSystem sys;
  abs_r.clear();
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  Vector6d J;
  auto add = [&](const Point& p, const Eigen::Vector3d& dir, const Point& q, double weight) {
    const double r = dir.dot(p - q);
    J.head<3>() = (p - t).cross(dir);
    J.tail<3>() = dir;
    const double w = weight * robustWeight(r, s2);
    const Vector6d wJ = w * J;
    for (int c = 0; c < 6; ++c)  // the lower triangle only (symmetric; mirrored below)
      for (int k = c; k < 6; ++k) sys.H(k, c) += wJ(k) * J(c);
    sys.g.noalias() += (w * r) * J;
    sys.sum_w += w;
    sys.sum_wr2 += w * r * r;
    return r;
  };
  for (const Match& m : matches) {
    const Point p = R * model.points[m.i] + t;
    const Eigen::Vector3d n = R * model.normals[m.i];
    const Point& q = scan.points[m.j];
    const double r = add(p, n, q, m.from_template ? 1.0 : config.scan_weight);
    abs_r.push_back(std::abs(r));
    if (!m.from_template) {
      ++sys.scan_matches;
      continue;
    }
    if (config.tangent_weight > 0) {
      // The offset along the tangent plane too (tangent_weight 1: point-to-point, the authors' metric).
      const Eigen::Vector3d a = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      const Eigen::Vector3d t1 = n.cross(a).normalized();
      add(p, t1, q, config.tangent_weight);
      add(p, n.cross(t1), q, config.tangent_weight);
    }
    sys.sum_r2 += r * r;
    ++sys.matches;
  }
  sys.H.triangularView<Eigen::StrictlyUpper>() = sys.H.transpose();
  return sys;
}

// Robust-weighted residual variance (m^2), never below (0.1 mm)^2: a noise-free synthetic fit
// must not claim infinite information.
double residualVariance(const LinearSystem& sys) {
  return std::max(sys.sum_w > 0 ? sys.sum_wr2 / sys.sum_w : 0.0, 1e-8);
}

}  // namespace

Vector6d deviation(const Pose& T, const Pose& T_prior) {
  const Eigen::AngleAxisd aa(T.linear() * T_prior.linear().transpose());
  Vector6d e;
  e << aa.angle() * aa.axis(), T.translation() - T_prior.translation();
  return e;
}

Pose moved(const Pose& T, const Vector6d& d) {
  Pose out = T;
  const Eigen::Vector3d omega = d.head<3>();
  if (omega.norm() > 0) out.linear() = Eigen::AngleAxisd(omega.norm(), omega.normalized()) * T.linear();
  out.translation() += d.tail<3>();
  return out;
}

RegistrationResult registerSurfaces(const Surface& model, const Surface& scan, const Pose& guess, double max_distance,
                                    const IcpConfig& config, const PosePrior* prior, FirstMatches* first) {
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
  if (model.points.empty()) return invalid("source (template) is empty");
  if (model.normals.size() != model.points.size() || model.index.size() != model.points.size())
    return invalid("source has " + std::to_string(model.points.size()) + " points but " +
                   std::to_string(model.normals.size()) + " normals and " + std::to_string(model.index.size()) +
                   " indexed");
  if (scan.points.empty()) return invalid("target (scan) is empty");
  if (scan.normals.size() != scan.points.size() || scan.index.size() != scan.points.size())
    return invalid("target has " + std::to_string(scan.points.size()) + " points but " +
                   std::to_string(scan.normals.size()) + " normals and " + std::to_string(scan.index.size()) +
                   " indexed");
  if (!(std::isfinite(max_distance) && max_distance > 0)) return invalid("max correspondence distance must be > 0");
  if (config.max_iterations < 1) return invalid("max_iterations must be >= 1");
  if (prior && !(prior->information.allFinite() && isValidPose(prior->T_cell_part, 1e-4) && prior->inflation > 0))
    return invalid("the prior is not finite");

  // Kernel scale: wide while the template is still far off (a part that moved 5 mm must not be
  // refused), then 3 robust sigmas of the last round's residuals, never below config.kernel_scale.
  double scale = config.kernel_scale > 0 ? std::max(config.kernel_scale, max_distance / 3) : 0.0;
  std::vector<double> abs_r;
  abs_r.reserve(model.points.size() + scan.points.size());
  // The matches are searched again only once the template has moved by more than
  // config.reassociate since they were (a template point's nearest voxel changes no sooner), and
  // always before the fit is declared converged.
  double length2 = 0;  // the template's mean squared distance from the part origin: a turn's lever
  for (const Point& p : model.points) length2 += p.squaredNorm();
  const double length = std::sqrt(length2 / static_cast<double>(model.points.size()));
  std::vector<Match> matches;
  Pose T = result.T_target_source, T_matched = T;
  bool stale = true;
  result.status = RegistrationStatus::kMaxIterations;
  LinearSystem sys;
  for (int iteration = 1; iteration <= config.max_iterations; ++iteration) {
    const bool matched_now = stale;
    if (stale) {
      if (iteration == 1 && first && first->filled && first->T.matrix() == T.matrix() &&
          first->max_distance == max_distance) {
        matches = first->matches;
      } else {
        associate(model, scan, T, max_distance, config, matches);
        if (iteration == 1 && first) *first = {true, T, max_distance, matches};
      }
      T_matched = T;
      stale = false;
      ++result.associations;
    }
    sys = linearize(model, scan, matches, T, scale * scale, config, abs_r);
    result.iterations = iteration;
    result.correspondences = sys.matches;
    result.scan_matches = sys.scan_matches;
    result.inlier_ratio = static_cast<double>(sys.matches) / static_cast<double>(model.points.size());
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
    if (config.kernel_scale > 0 && !abs_r.empty()) {
      std::nth_element(abs_r.begin(), abs_r.begin() + abs_r.size() / 2, abs_r.end());
      scale = std::max(config.kernel_scale, 3 * 1.4826 * abs_r[abs_r.size() / 2]);
    }
    // Gauss-Newton step; with a prior, the cost is the residuals over their variance (inflated)
    // plus the deviation from the prior's pose in its information.
    Matrix6d A = sys.H;
    Vector6d g = sys.g;
    if (prior) {
      const double data = 1.0 / (residualVariance(sys) * prior->inflation);
      A = data * sys.H + prior->information;
      g = data * sys.g + prior->information * deviation(T, prior->T_cell_part);
    }
    A.diagonal().array() += 1e-12 * std::max(A.diagonal().maxCoeff(), 1e-300);  // numerical floor
    Vector6d delta = -A.ldlt().solve(g);
    // A trust region: no step may move the template further than the association can follow.
    delta /= std::max(
        {1.0, delta.tail<3>().norm() / (0.5 * max_distance), delta.head<3>().norm() / config.max_step_rotation});
    if (!delta.allFinite()) {
      result.status = RegistrationStatus::kDegenerate;
      result.reason = "the ICP normal equations are singular";
      result.T_target_source = guess;
      result.T_target_source.linear() = orthonormalized(guess.linear());
      return result;
    }
    T = moved(T, delta);
    if (delta.tail<3>().norm() < config.convergence_translation &&
        delta.head<3>().norm() < config.convergence_rotation) {
      if (matched_now) {
        result.status = RegistrationStatus::kConverged;
        break;
      }
      stale = true;  // converged on older matches: search them again at this pose
    } else if (translationDistance(T, T_matched) + length * rotationAngle(T.linear(), T_matched.linear()) >
               config.reassociate) {
      stale = true;
    }
  }
  T.linear() = orthonormalized(T.linear());
  result.T_target_source = T;
  result.information = sys.H / residualVariance(sys);
  if (result.status == RegistrationStatus::kMaxIterations)
    result.reason = "stopped after " + std::to_string(config.max_iterations) + " iterations without converging";
  return result;
}

RegistrationResult registerSurfaces(const Cloud& model, const Cloud& model_normals, const Cloud& scan,
                                    const Cloud& scan_normals, const Pose& guess, double max_distance,
                                    const IcpConfig& config) {
  const double cell = std::isfinite(max_distance) && max_distance > 0 ? max_distance : 1.0;
  const ScanIndex model_index(model, cell), scan_index(scan, cell);
  return registerSurfaces({model, model_normals, model_index}, {scan, scan_normals, scan_index}, guess, max_distance,
                          config);
}

}  // namespace depowder::tracker
