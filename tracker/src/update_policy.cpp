#include "depowder/tracker/update_policy.hpp"

#include <cmath>

namespace depowder::tracker {

UpdateDecision conditionalUpdate(const Pose& T_cell_part, double eta, const UpdateReference& last,
                                 const UpdateThresholds& thresholds) {
  UpdateDecision d;
  // Eq. 1: |R_i - R_last| is the geodesic angle of R_last^T R_i; |t_i - t_last| the Euclidean
  // distance; |eta_i - eta_last| the absolute progress change (Alg. 1, line 12 prints it
  // without the bars; Eq. 1 has them, and a falling eta is as much an appearance change).
  d.rotation_change = rotationAngle(last.T_cell_part.linear(), T_cell_part.linear());
  d.translation_change = translationDistance(T_cell_part, last.T_cell_part);
  d.progress_change = std::abs(eta - last.eta);
  d.rotation = d.rotation_change > thresholds.delta1_rad;
  d.translation = d.translation_change > thresholds.delta2;
  d.progress = d.progress_change > thresholds.delta3;
  d.update = d.rotation || d.translation || d.progress;
  return d;
}

UpdateDecision decideTemplateUpdate(Method method, const Pose& T_cell_part, double eta, const UpdateReference& last,
                                    const UpdateThresholds& thresholds) {
  UpdateDecision d = conditionalUpdate(T_cell_part, eta, last, thresholds);
  switch (method) {
    case Method::kCu:  // Strategy 3, Eq. 1
      break;
    case Method::kContinuous:  // Strategy 2: the overlap with the scan, every frame
      d.update = true;
      break;
    case Method::kVanilla:  // Strategy 1: the whole CAD model, never updated
      d.update = false;
      break;
  }
  return d;
}

UpdateThresholds thresholdsOf(const TrackerConfig& config) {
  return {config.delta1_deg * M_PI / 180.0, config.delta2, config.delta3};
}

}  // namespace depowder::tracker
