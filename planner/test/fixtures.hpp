// Shared test fixtures: the arm beside the box and a few obstacles.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/robot/kinematics.hpp"

namespace depowder::planner::test {

/// The VS-6577 beside the box's -x wall (the default cell's base pose), a nozzle 25 cm below the flange (the
/// 20 cm deep box needs it: with a shorter tool the forearm reaches the walls' rim).
inline std::shared_ptr<robot::ArmConfig> cellArm() {
  auto arm = std::make_shared<robot::ArmConfig>();
  arm->T_cell_base = makePoseRpy({-0.55, 0.0, 0.0}, 0, 0, 0.0);  // as config/cell.yaml
  arm->T_flange_nozzle = makePoseRpy({0.0, 0.0, 0.25}, 0, 0, 0);
  return arm;
}

/// A synthetic powder contour, as the progress estimator would report it for a powder surface
/// at height `powder`: the visible part (above the powder, less 1 cm) projected to xy, its
/// support in 72 directions plus `gap` (the estimator's band sits ~xi + 2.5 mm out).
inline Cloud syntheticContour(const Mesh& posed, double powder, double gap = 0.0125) {
  Eigen::AlignedBox2d b;
  for (const auto& v : posed.vertices)
    if (v.z() >= powder - 0.01) b.extend(v.head<2>());
  if (b.isEmpty())
    for (const auto& v : posed.vertices) b.extend(v.head<2>());
  const Eigen::Vector2d c = b.center();
  Cloud contour;
  for (int k = 0; k < 72; ++k) {
    const double a = 2 * 3.14159265358979323846 * k / 72;
    const Eigen::Vector2d u(std::cos(a), std::sin(a));
    double extent = 0;
    for (const auto& v : posed.vertices)
      if (v.z() >= powder - 0.01) extent = std::max(extent, (v.head<2>() - c).dot(u));
    const Eigen::Vector2d p = c + (extent + gap) * u;
    contour.emplace_back(p.x(), p.y(), powder);
  }
  return contour;
}

}  // namespace depowder::planner::test
