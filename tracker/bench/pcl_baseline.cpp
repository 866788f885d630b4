#include "pcl_baseline.hpp"

#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include <chrono>
#include <cmath>

#include "depowder/progress/progress.hpp"
#include "depowder/tracker/registration.hpp"
#include "depowder/tracker/template.hpp"
#include "depowder/tracker/update_policy.hpp"

namespace depowder::tracker::bench {

using PclCloud = pcl::PointCloud<pcl::PointXYZ>;

struct PclTracker::Impl {
  SurfaceSamples cad;
  progress::EtaEstimator eta_estimator;  // Eq. 2 on P_cad thinned to icp_leaf, as PartTracker does
  TrackerConfig config;
  double xi;
  Pose T_init, T;
  bool started = false;
  double eta = 0;
  UpdateReference last;
  Indices tmpl;
  PclCloud::Ptr source{new PclCloud};  // the template thinned to 5 mm, part frame
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;

  double etaAt(const Pose& pose, const Cloud& scan) {
    const progress::ProgressEstimate e = eta_estimator.estimate(pose, scan);
    return e.status == progress::Status::kOk ? e.eta : std::nan("");
  }
  void setTemplate(Indices indices) {
    tmpl = std::move(indices);
    source->clear();
    for (const std::uint32_t i : thinned(cad.points, tmpl, config.icp_leaf)) {
      const Point& p = cad.points[i];
      source->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    }
  }
};

PclTracker::PclTracker(const SurfaceSamples& cad, const Pose& T_cell_part_init, double xi, const TrackerConfig& config)
    : impl_(std::make_unique<Impl>()) {
  impl_->cad = cad;
  impl_->eta_estimator = progress::EtaEstimator(
      gather(cad.points, thinned(cad.points, allIndices(cad.points.size()), config.icp_leaf)), xi, config.progress);
  impl_->config = config;
  impl_->xi = xi;
  impl_->T_init = impl_->T = T_cell_part_init;
  impl_->last = {T_cell_part_init, 0.0};
  // The authors' settings, in metres: max correspondence distance xi; 30 iterations;
  // transformation epsilon 5e-5 cm^2 (PCL compares it with the squared translation of an
  // iteration) = 5e-9 m^2, and the rotation threshold PCL derives from it, cos >= 1 - 5e-5;
  // Euclidean fitness epsilon 5e-5 (a relative MSE change in PCL 1.13: unit-free).
  impl_->icp.setMaxCorrespondenceDistance(xi);
  impl_->icp.setMaximumIterations(30);
  impl_->icp.setTransformationEpsilon(5e-9);
  impl_->icp.setTransformationRotationEpsilon(1.0 - 5e-5);
  impl_->icp.setEuclideanFitnessEpsilon(5e-5);
}

PclTracker::~PclTracker() = default;

PclFrame PclTracker::track(const Cloud& scan) {
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  PclFrame out;
  // Crop: an axis-aligned box of +-12 cm around the current position (the authors' CropBox).
  Cloud crop;
  PclCloud::Ptr target(new PclCloud);
  const Eigen::Vector3d c = m.T.translation();
  for (const Point& p : scan)
    if ((p - c).cwiseAbs().maxCoeff() <= 0.12) {
      crop.push_back(p);
      target->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    }
  if (crop.size() >= 3) {
    const ScanIndex grid(crop, m.xi);
    if (!m.started) {
      const auto p0 = std::chrono::steady_clock::now();
      const double eta = m.etaAt(m.T_init, crop);
      out.progress_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - p0).count();
      if (!std::isnan(eta) && eta > m.config.eta1) {
        m.started = true;
        m.eta = eta;
        m.setTemplate(deriveTemplate(m.cad.points, m.T, grid, m.xi));  // Alg. 1, lines 4-6
        m.last = {m.T, m.eta};
      }
    }
    if (m.started && m.source->size() >= 3) {
      // Alg. 1, lines 8-9, with PCL: the part-frame template from the current pose.
      m.icp.setInputSource(m.source);
      m.icp.setInputTarget(target);
      PclCloud aligned;
      m.icp.align(aligned, m.T.matrix().cast<float>());
      out.register_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      out.converged = m.icp.hasConverged();
      Pose T(m.icp.getFinalTransformation().cast<double>());
      T.linear() = orthonormalized(T.linear());
      if (T.matrix().allFinite()) m.T = T;
      // Lines 10-16: the same Eq. 2 and Eq. 1 code as CU-ICP.
      const auto p0 = std::chrono::steady_clock::now();
      if (const double eta = m.etaAt(m.T, crop); !std::isnan(eta)) m.eta = eta;
      out.progress_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - p0).count();
      if (decideTemplateUpdate(Method::kCu, m.T, m.eta, m.last, thresholdsOf(m.config)).update) {
        m.setTemplate(deriveTemplate(m.cad.points, m.T, grid, m.xi));
        m.last = {m.T, m.eta};
      }
    }
  }
  out.T_cell_part = m.T;
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace depowder::tracker::bench
