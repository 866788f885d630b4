// The part's footprint: its CAD surface samples projected onto the cell's xy plane
// (the authors project scan and part to z = 0, REFERENCE.md). The powder band of
// Eq. 2 and the contour the planner follows are measured from this silhouette.
//
// Why the whole posed CAD and not only the visible part segment: the silhouette
// does not change with visibility or scan noise, and a band point, being more than
// xi from every CAD sample in 2-D, is more than xi from the part in 3-D, so it is
// powder by construction. Holes of the silhouette (the inside of a cup or of a
// standing pipe) are filled, so powder held inside the part never counts as band.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/point_grid.hpp"

namespace depowder::progress {

using Point2 = Eigen::Vector2d;
using Polyline2 = std::vector<Point2>;

class Footprint {
 public:
  Footprint() = default;
  /// `cad_in_cell`: posed CAD samples (finite). `cell`: raster cell, m. `close_radius`: gaps and
  /// holes narrower than 2 * close_radius are closed (m). `reach`: the raster covers the silhouette
  /// grown by at least this much (m), the farthest distance you will ask about.
  Footprint(const Cloud& cad_in_cell, double cell, double close_radius, double reach);

  bool empty() const { return width_ == 0; }

  /// False if p is over the filled silhouette grown by close_radius (or off the raster). Near the
  /// grown edge this is only as good as the raster: decide that edge with distance().
  bool outside(const Point2& p) const;
  /// Exact 2-D distance from p to the nearest projected CAD sample if it is within `radius`,
  /// else +inf.
  double distance(const Point2& p, double radius) const;
  /// distance(p, radius) <= radius, found sooner: stops at the first projected sample in range.
  bool within(const Point2& p, double radius) const;

  /// The outermost closed iso-line at `level` m from the silhouette (level > close_radius),
  /// counter-clockwise, resampled every `spacing` m (at least 8 vertices). Empty if none.
  Polyline2 outerContour(double level, double spacing) const;

  /// Raster distance (m) from the centre of p's cell to the nearest cell holding a sample;
  /// -1 inside a filled hole; +inf off the raster. For tests and the viewer.
  double rasterDistance(const Point2& p) const;

 private:
  int cellIndex(const Point2& p) const;  ///< -1 off the raster

  std::shared_ptr<const Cloud> flat_;  ///< samples at z = 0 (shared: grid_ points into it)
  PointGrid grid_;
  Point2 origin_ = Point2::Zero();  ///< centre of cell (0, 0)
  double cell_ = 0;
  int width_ = 0, height_ = 0;
  std::vector<float> field_;  ///< per cell: distance to the silhouette (m), -1 in filled holes
  std::vector<char> outside_;
};

}  // namespace depowder::progress
