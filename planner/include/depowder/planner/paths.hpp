// Nozzle paths of the three phases (paper Sec. III-B), as tip positions in the cell frame:
//  - phases 1-2: a closed vacuum loop around the part at the stand-off from its surface,
//    one layer below the powder height, seeded from the powder contour (or, without a
//    usable contour, from the part's footprint);
//  - phase 3: a boustrophedon raster over the part's footprint, above its top surface.
// Pure geometry: no IK, no collision with other bodies (see waypoints.hpp for that).
#pragma once

#include <string>

#include "depowder/geometry.hpp"
#include "depowder/planner/collision.hpp"
#include "depowder/planner/config.hpp"

namespace depowder::planner {

enum class PathStatus {
  kOk,
  kInvalidPose,     ///< the part pose has NaN / is not a rigid transform
  kInvalidHeight,   ///< the powder height is not finite
  kEmptyContour,    ///< no contour points
  kInvalidContour,  ///< NaN points, too few points, or a polyline that does not enclose the part
  kNoPath,          ///< nothing left after generation (degenerate geometry)
};
const char* toString(PathStatus s);

/// Where a vacuum loop's shape came from.
enum class LoopSource { kContour, kFootprint };
const char* toString(LoopSource s);

struct LoopResult {
  PathStatus status = PathStatus::kNoPath;
  std::string reason;  ///< what went wrong, when status != kOk
  LoopSource source = LoopSource::kContour;
  double height = 0;        ///< m, tip height of the loop (cell z)
  Cloud tips;               ///< closed loop (last == first), direction per config, cell frame
  double min_standoff = 0;  ///< m, smallest nozzle-axis distance to the part over the loop
  double max_standoff = 0;  ///< m, largest
  bool ok() const { return status == PathStatus::kOk; }
};

/// Lowest and highest point of the part at T_cell_part (m, cell z): H_min and H_max of Eq. 2.
struct HeightRange {
  double min = 0;
  double max = 0;
};
HeightRange partHeights(const PartShape& part, const Pose& T_cell_part);

/// Lowest tip height of a loop: `undercut` below the part's bottom, no lower than the floor
/// clearance.
double loopFloor(const PartShape& part, const Pose& T_cell_part, const VacuumConfig& config);

/// Tip height of the next loop: one layer below the powder, no lower than loopFloor.
double loopHeight(const PartShape& part, const Pose& T_cell_part, double powder_height, const VacuumConfig& config);

/// Phases 1-2: pushes the powder contour (ordered closed polyline, cell frame) out to the
/// stand-off from the part at T_cell_part, at loopHeight(powder_height); the loop starts at
/// its point nearest `nozzle_now`, so a regenerated loop continues where the nozzle is.
LoopResult contourLoop(const PartShape& part, const Pose& T_cell_part, const Cloud& contour, double powder_height,
                       const Point& nozzle_now, const PlannerConfig& config);

/// The same loop seeded from the part's footprint (its convex hull in xy grown by the
/// stand-off), for when there is no usable contour.
LoopResult footprintLoop(const PartShape& part, const Pose& T_cell_part, double powder_height, const Point& nozzle_now,
                         const PlannerConfig& config);

struct RasterResult {
  PathStatus status = PathStatus::kNoPath;
  std::string reason;
  Cloud tips;  ///< boustrophedon order, starting at the corner nearest the nozzle
  int lines = 0;
  bool ok() const { return status == PathStatus::kOk; }
};

/// Phase 3: raster lines `blast.spacing` apart over the footprint (grown by `overhang`), the
/// tip `blast.standoff` above the highest part point within the nozzle's reach.
RasterResult blastRaster(const PartShape& part, const Pose& T_cell_part, const Point& nozzle_now,
                         const PlannerConfig& config);

}  // namespace depowder::planner
