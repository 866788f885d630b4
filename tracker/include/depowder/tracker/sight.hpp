// What the cameras' lines of sight say about a pose. ICP only asks whether each template point
// has a scan point near it; it cannot tell a pose whose CAD model floats in front of what the
// cameras saw (a fallen pipe's leg estimated 30 deg up in the air, matched nowhere and so left
// out of the template) from the truth. Seen from each camera, a CAD point on the near side of
// the scanned surface is in space the camera saw through: evidence against the pose.
#pragma once

#include <vector>

#include "depowder/geometry.hpp"

namespace depowder::tracker {

/// Counts over the CAD points tested (each point once, over all cameras).
struct SightCheck {
  enum Verdict : unsigned char { kUnknown = 0, kSeen = 1, kInFront = 2, kHidden = 3 };
  int seen = 0;      ///< on the scanned surface (within the tolerance) for some camera
  int in_front = 0;  ///< in front of the scanned surface for some camera and seen by none: free space
  int hidden = 0;    ///< behind the scanned surface for every camera that looked (powder, the part itself)
  int unknown = 0;   ///< no camera faces it or no scan point along its line of sight
  /// The points judged: 0 when no check was made (TrackResult::sight on a frame without the refit).
  int total() const { return seen + in_front + hidden + unknown; }
};

/// The scan as range images, one per camera, over the lines of sight through `region` (cell
/// frame): the nearest scan point per pixel of `pixel` radians. The scan is the cameras' merged
/// cloud, so a camera's image also holds what only the other camera saw; a point judged in front
/// lies between the camera and a scanned surface, which is evidence against the pose unless
/// something the scan does not hold (the box walls are cropped out) hid that surface from it.
class SightImages {
 public:
  SightImages(const Cloud& scan, const std::vector<Point>& viewpoints, const Eigen::AlignedBox3d& region,
              double pixel = 0.008);

  /// Judges `points` (cell frame) with outward unit `normals` (cell frame); a point within
  /// `tolerance` (m) of the scanned range is seen. Writes each point's SightCheck::Verdict to
  /// `verdict` if given.
  SightCheck check(const Cloud& points, const Cloud& normals, double tolerance,
                   std::vector<unsigned char>* verdict = nullptr) const;

 private:
  struct Image {
    Point eye;
    Eigen::Vector3d axis, u, v;  ///< the optical axis and the image plane's directions
    double x0 = 0, y0 = 0;       ///< tangent-plane coordinates of pixel (0, 0)
    double pixel = 0;            ///< tangent-plane units (about radians) per pixel
    int width = 0, height = 0;
    std::vector<float> range;  ///< m; +inf: no scan point
    int pixelOf(const Point& p, double* range_out) const;
  };
  std::vector<Image> images_;
};

}  // namespace depowder::tracker
