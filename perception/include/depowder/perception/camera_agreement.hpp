// Do the cameras still agree? During a run, two cameras that see the same powder must see it
// at the same height. A camera knocked or loosened tilts or shifts its whole surface: the
// difference of the two cameras' heights over the box is then a plane, whose offset and tilt
// this measures (a camera's turn about a horizontal axis or its rise; a slide along the powder
// or a turn about the vertical does not show on a flat surface: depowder-calibrate finds those).
#pragma once

#include <Eigen/Core>
#include <string>

#include "depowder/geometry.hpp"

namespace depowder::perception {

struct AgreementConfig {
  double period = 1.0;         ///< s of frames between checks; <= 0: off
  double cell = 0.01;          ///< m, side of the grid cells whose mean heights are compared
  double wall_margin = 0.02;   ///< m of the box interior next to the walls left out
  int min_points = 3;          ///< points of each camera a cell needs
  int min_cells = 50;          ///< fewer cells seen by both: no figure
  double max_offset = 0.002;   ///< m: the surfaces further apart than this at the box centre are flagged
  double max_tilt_deg = 0.25;  ///< deg: or tilted to each other by more than this
  int flag_after = 3;          ///< checks in a row over a limit before it is flagged
};

struct Agreement {
  bool valid = false;                               ///< enough cells seen by both
  int cells = 0;                                    ///< cells seen by both, and kept by the robust fit
  double offset = 0;                                ///< m, the camera's surface above the reference's at the box centre
  double tilt_deg = 0;                              ///< deg between the two surfaces
  Eigen::Vector2d slope = Eigen::Vector2d::Zero();  ///< d(offset)/dx, d(offset)/dy
};

/// The plane fitted (least squares, twice after dropping cells beyond 3 MADs: parts, the
/// nozzle, slopes seen from two sides) to the differences of the mean heights of `camera`
/// and `reference` (cell-frame points) over the interior of a box of `box_size`.
Agreement compareHeights(const Cloud& camera, const Cloud& reference, const Eigen::Vector3d& box_size,
                         const AgreementConfig& config);

}  // namespace depowder::perception
