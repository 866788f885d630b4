// When the template is re-derived: the only line in which the three methods differ.
#pragma once

#include "depowder/geometry.hpp"
#include "depowder/tracker/config.hpp"

namespace depowder::tracker {

/// The pose and progress at the last template update: R_last, t_last, eta_last (Alg. 1, lines 14-16).
struct UpdateReference {
  Pose T_cell_part = Pose::Identity();
  double eta = 0;
};

struct UpdateThresholds {
  double delta1_rad = 30.0 * M_PI / 180.0;  ///< rad, rotation
  double delta2 = 0.05;                     ///< m, translation
  double delta3 = 0.15;                     ///< progress fraction
};

struct UpdateDecision {
  bool update = false;
  bool rotation = false;          ///< |R_i - R_last| > delta1 (geodesic angle)
  bool translation = false;       ///< |t_i - t_last| > delta2
  bool progress = false;          ///< |eta_i - eta_last| > delta3
  double rotation_change = 0;     ///< rad
  double translation_change = 0;  ///< m
  double progress_change = 0;     ///< |eta_i - eta_last|
};

/// Eq. 1 (Alg. 1, line 12): update if the rotation, translation or progress changed by
/// more than delta1, delta2 or delta3 since the last update. Strict inequalities, as printed.
UpdateDecision conditionalUpdate(const Pose& T_cell_part, double eta, const UpdateReference& last,
                                 const UpdateThresholds& thresholds);

/// The update policy of each method: vanilla never (its template is the whole CAD model),
/// continuous every frame, CU-ICP by Eq. 1.
UpdateDecision decideTemplateUpdate(Method method, const Pose& T_cell_part, double eta, const UpdateReference& last,
                                    const UpdateThresholds& thresholds);

/// The thresholds of a tracker config (delta1 converted to radians).
UpdateThresholds thresholdsOf(const TrackerConfig& config);

}  // namespace depowder::tracker
