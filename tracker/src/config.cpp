#include "depowder/tracker/config.hpp"

#include <cmath>
#include <map>
#include <stdexcept>

namespace depowder::tracker {

const char* toString(Method method) {
  switch (method) {
    case Method::kCu:
      return "cu";
    case Method::kContinuous:
      return "continuous";
    case Method::kVanilla:
      return "vanilla";
  }
  return "?";
}

std::optional<Method> methodFromString(const std::string& name) {
  for (Method m : {Method::kCu, Method::kContinuous, Method::kVanilla})
    if (name == toString(m)) return m;
  return std::nullopt;
}

namespace {
bool positive(double v) { return std::isfinite(v) && v > 0; }
bool nonNegative(double v) { return std::isfinite(v) && v >= 0; }
bool fraction(double v) { return std::isfinite(v) && v >= 0 && v <= 1; }
}  // namespace

std::string validate(const TrackerConfig& c) {
  if (!positive(c.delta1_deg) || c.delta1_deg > 180) return "delta1_deg must be in (0, 180] deg";
  if (!positive(c.delta2)) return "delta2 must be > 0 m";
  if (!positive(c.delta3) || c.delta3 > 1) return "delta3 must be in (0, 1]";
  if (!fraction(c.eta1)) return "eta1 must be in [0, 1]";
  if (!positive(c.cad_spacing) || c.cad_spacing > 0.05) return "cad_spacing must be in (0, 0.05] m";
  if (!nonNegative(c.icp_leaf) || c.icp_leaf > 0.05) return "icp_leaf must be in [0, 0.05] m";
  if (!nonNegative(c.crop_margin) || c.crop_margin > 1) return "crop_margin must be in [0, 1] m";
  if (!fraction(c.refit_margin)) return "refit_margin must be in [0, 1] (0 = never refit)";
  if (!fraction(c.refit_min_eta)) return "refit_min_eta must be in [0, 1]";
  if (!nonNegative(c.refit_min_rotation_deg) || c.refit_min_rotation_deg > 180)
    return "refit_min_rotation_deg must be in [0, 180] deg";
  if (c.min_scan_points < 1) return "min_scan_points must be >= 1";
  if (c.icp.max_iterations < 1) return "icp.max_iterations must be >= 1";
  if (!nonNegative(c.icp.max_correspondence_distance) || c.icp.max_correspondence_distance > 0.5)
    return "icp.max_correspondence_distance must be in [0, 0.5] m (0 = the part's xi)";
  if (!nonNegative(c.icp.convergence_translation)) return "icp.convergence_translation must be >= 0 m";
  if (!nonNegative(c.icp.convergence_rotation)) return "icp.convergence_rotation must be >= 0 rad";
  if (!nonNegative(c.icp.kernel_scale)) return "icp.kernel_scale must be >= 0 m";
  if (!(std::isfinite(c.icp.normal_min_cos) && c.icp.normal_min_cos >= -1 && c.icp.normal_min_cos <= 1))
    return "icp.normal_min_cos must be in [-1, 1]";
  if (!positive(c.icp.normal_radius) || c.icp.normal_radius > 0.1) return "icp.normal_radius must be in (0, 0.1] m";
  if (!fraction(c.icp.tangent_weight)) return "icp.tangent_weight must be in [0, 1]";
  if (!fraction(c.icp.scan_weight)) return "icp.scan_weight must be in [0, 1]";
  if (!nonNegative(c.visibility.powder_radius) || c.visibility.powder_radius > 0.2)
    return "visibility.powder_radius must be in [0, 0.2] m (0 = no powder test)";
  if (!std::isfinite(c.visibility.powder_margin) || std::abs(c.visibility.powder_margin) > 0.05)
    return "visibility.powder_margin must be in [-0.05, 0.05] m";
  if (!std::isfinite(c.visibility.cover) || c.visibility.cover < 0 || c.visibility.cover > 0.02)
    return "visibility.cover must be in [0, 0.02] m";
  if (!std::isfinite(c.visibility.powder_scan_margin) || c.visibility.powder_scan_margin < 0 ||
      c.visibility.powder_scan_margin > 0.05)
    return "visibility.powder_scan_margin must be in [0, 0.05] m";
  if (!(std::isfinite(c.filter.data_inflation) && c.filter.data_inflation >= 0))
    return "filter.data_inflation must be >= 0 (0 = off)";
  if (!positive(c.filter.q_yaw_deg) || !positive(c.filter.q_tilt_deg) || !positive(c.filter.q_xy) ||
      !positive(c.filter.q_z))
    return "filter.q_yaw_deg, q_tilt_deg, q_xy and q_z must be > 0";
  if (!positive(c.filter.still_turn) || c.filter.still_turn > 1) return "filter.still_turn must be in (0, 1]";
  if (!nonNegative(c.filter.moving_translation) || !nonNegative(c.filter.moving_rotation_deg))
    return "filter.moving_translation and filter.moving_rotation_deg must be >= 0";
  if (c.filter.moving_frames < 1) return "filter.moving_frames must be >= 1";
  if (!(std::isfinite(c.filter.moving_full) && c.filter.moving_full >= 1)) return "filter.moving_full must be >= 1";
  if (!positive(c.filter.fall_sink)) return "filter.fall_sink must be > 0 m";
  if (!nonNegative(c.filter.fall_tilt_deg)) return "filter.fall_tilt_deg must be >= 0 (0 = no fall gate)";
  if (!positive(c.filter.reset_chi2) || !positive(c.filter.reset_deg) || !positive(c.filter.reset_m))
    return "filter.reset_chi2, filter.reset_deg and filter.reset_m must be > 0";
  if (c.filter.reset_frames < 0) return "filter.reset_frames must be >= 0 (0 = no disagreement check)";
  if (c.filter.check_every < 1) return "filter.check_every must be >= 1 (1 = every frame)";
  if (!fraction(c.filter.reset_inlier_margin)) return "filter.reset_inlier_margin must be in [0, 1]";
  if (!fraction(c.filter.reset_unexplained)) return "filter.reset_unexplained must be in [0, 1]";
  if (!positive(c.filter.initial_deg) || !positive(c.filter.initial_m))
    return "filter.initial_deg and filter.initial_m must be > 0";
  if (!positive(c.icp.max_step_rotation)) return "icp.max_step_rotation must be > 0 rad";
  if (!nonNegative(c.icp.reassociate) || c.icp.reassociate > 0.05) return "icp.reassociate must be in [0, 0.05] m";
  if (c.icp.min_correspondences < 6) return "icp.min_correspondences must be >= 6";
  if (!fraction(c.status.tracking_min_inlier_ratio)) return "status.tracking_min_inlier_ratio must be in [0, 1]";
  if (!fraction(c.status.lost_min_inlier_ratio)) return "status.lost_min_inlier_ratio must be in [0, 1]";
  if (c.status.lost_min_inlier_ratio > c.status.tracking_min_inlier_ratio)
    return "status.lost_min_inlier_ratio must not exceed status.tracking_min_inlier_ratio";
  if (!positive(c.status.tracking_max_rms)) return "status.tracking_max_rms must be > 0 m";
  if (!positive(c.status.lost_max_rms) || c.status.lost_max_rms < c.status.tracking_max_rms)
    return "status.lost_max_rms must be >= status.tracking_max_rms";
  return "";
}

void setField(TrackerConfig& config, const std::string& key, double value) {
  TrackerConfig c = config;  // changed only if the result validates
  const std::map<std::string, double*> fields{{"delta1_deg", &c.delta1_deg},
                                              {"delta2", &c.delta2},
                                              {"delta3", &c.delta3},
                                              {"eta1", &c.eta1},
                                              {"cad_spacing", &c.cad_spacing},
                                              {"icp_leaf", &c.icp_leaf},
                                              {"crop_margin", &c.crop_margin},
                                              {"refit_margin", &c.refit_margin},
                                              {"refit_min_eta", &c.refit_min_eta},
                                              {"refit_min_rotation_deg", &c.refit_min_rotation_deg},
                                              {"icp.max_correspondence_distance", &c.icp.max_correspondence_distance},
                                              {"icp.convergence_translation", &c.icp.convergence_translation},
                                              {"icp.convergence_rotation", &c.icp.convergence_rotation},
                                              {"icp.kernel_scale", &c.icp.kernel_scale},
                                              {"icp.normal_min_cos", &c.icp.normal_min_cos},
                                              {"icp.normal_radius", &c.icp.normal_radius},
                                              {"icp.tangent_weight", &c.icp.tangent_weight},
                                              {"icp.scan_weight", &c.icp.scan_weight},
                                              {"visibility.powder_radius", &c.visibility.powder_radius},
                                              {"visibility.powder_margin", &c.visibility.powder_margin},
                                              {"visibility.cover", &c.visibility.cover},
                                              {"visibility.powder_scan_margin", &c.visibility.powder_scan_margin},
                                              {"icp.max_step_rotation", &c.icp.max_step_rotation},
                                              {"icp.reassociate", &c.icp.reassociate},
                                              {"filter.data_inflation", &c.filter.data_inflation},
                                              {"filter.q_yaw_deg", &c.filter.q_yaw_deg},
                                              {"filter.q_tilt_deg", &c.filter.q_tilt_deg},
                                              {"filter.q_xy", &c.filter.q_xy},
                                              {"filter.q_z", &c.filter.q_z},
                                              {"filter.initial_deg", &c.filter.initial_deg},
                                              {"filter.still_turn", &c.filter.still_turn},
                                              {"filter.moving_translation", &c.filter.moving_translation},
                                              {"filter.moving_rotation_deg", &c.filter.moving_rotation_deg},
                                              {"filter.moving_full", &c.filter.moving_full},
                                              {"filter.fall_sink", &c.filter.fall_sink},
                                              {"filter.fall_tilt_deg", &c.filter.fall_tilt_deg},
                                              {"filter.initial_m", &c.filter.initial_m},
                                              {"filter.reset_chi2", &c.filter.reset_chi2},
                                              {"filter.reset_deg", &c.filter.reset_deg},
                                              {"filter.reset_m", &c.filter.reset_m},
                                              {"filter.reset_inlier_margin", &c.filter.reset_inlier_margin},
                                              {"filter.reset_unexplained", &c.filter.reset_unexplained},
                                              {"progress.grid_cell", &c.progress.grid_cell},
                                              {"progress.contour_spacing", &c.progress.contour_spacing},
                                              {"progress.footprint_reuse", &c.progress.footprint_reuse}};
  const std::map<std::string, int*> whole{{"icp.max_iterations", &c.icp.max_iterations},
                                          {"filter.moving_frames", &c.filter.moving_frames},
                                          {"filter.reset_frames", &c.filter.reset_frames},
                                          {"filter.check_every", &c.filter.check_every}};
  if (!std::isfinite(value)) throw std::invalid_argument("tracker " + key + ": not a finite number");
  if (const auto it = whole.find(key); it != whole.end()) {
    if (value != std::floor(value) || std::abs(value) > 1e9)
      throw std::invalid_argument("tracker " + key + ": a whole number of at most 1e9, not " + std::to_string(value));
    *it->second = static_cast<int>(value);
  } else if (const auto f = fields.find(key); f != fields.end()) {
    *f->second = value;
  } else {
    std::string known;
    for (const auto& w : whole) known += (known.empty() ? "" : ", ") + w.first;
    for (const auto& d : fields) known += ", " + d.first;
    throw std::invalid_argument("unknown tracker key '" + key + "' (known: " + known + ")");
  }
  if (const std::string why = validate(c); !why.empty()) throw std::invalid_argument("tracker " + key + ": " + why);
  config = c;
}

}  // namespace depowder::tracker
