// Depth image -> points in the cell frame: deprojection with the camera's
// intrinsics, extrinsics, range and NaN filtering, and the crop to the build box.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/perception/status.hpp"

namespace depowder::perception {

/// Pinhole model and pose of one depth camera (the fields depth_image_t carries).
struct PinholeCamera {
  std::string name;
  int width = 0;   ///< pixels
  int height = 0;  ///< pixels
  double fx = 0;   ///< pixels: u = fx * x / z + cx, v = fy * y / z + cy
  double fy = 0;
  double cx = 0;
  double cy = 0;
  double min_range = 0;    ///< m, distance from the camera centre (ray length, as the L515 and the simulator
                           ///< measure it); nearer returns are invalid
  double max_range = 100;  ///< m, same distance; farther returns are invalid
  Pose T_cell_camera = Pose::Identity();  ///< camera frame: x right, y down, z forward
};

/// One depth frame (no LCM types; the executable converts depth_image_t).
struct DepthImage {
  std::int64_t utime = 0;  ///< capture time, us
  std::int64_t frame = 0;  ///< per-camera counter
  int width = 0;           ///< pixels, as the header says
  int height = 0;
  double depth_unit = 0.00025;       ///< m per count (L515: 0.25 mm)
  std::vector<std::uint16_t> depth;  ///< row-major z in counts, 0 = no return
};

/// What became of the pixels (or points) of one frame.
struct FrameCounts {
  std::size_t inputs = 0;        ///< pixels or points looked at
  std::size_t no_return = 0;     ///< 0 or non-finite
  std::size_t out_of_range = 0;  ///< distance from the camera outside [min_range, max_range]
  std::size_t outside_crop = 0;  ///< valid, but outside the crop box
  std::size_t kept = 0;
};

/// One camera's frame as points in the cell frame, valid and inside the crop box.
struct CameraCloud {
  FrameError error;  ///< kOk, or why the frame was rejected (then `points` is empty)
  Cloud points;
  FrameCounts counts;
};

/// The crop region: the box interior (cell origin at the floor centre, z up) grown by
/// `margin` (m) on every side.
Eigen::AlignedBox3d cropBox(const Eigen::Vector3d& box_size, double margin);

/// Checks the header of a depth frame against its camera: sizes, finite positive
/// intrinsics and depth unit, a rigid pose, 0 <= min_range < max_range.
FrameError checkDepthImage(const DepthImage& image, const PinholeCamera& camera);

/// Deprojects every pixel with a return in range, moves it to the cell frame with
/// T_cell_camera and keeps it if it lies in `crop`. Rejects a bad header (see
/// checkDepthImage) and a frame with no valid return at all.
CameraCloud deproject(const DepthImage& image, const PinholeCamera& camera, const Eigen::AlignedBox3d& crop);

/// deproject() for a stream of frames: per-pixel tables are kept between frames, holding for
/// every pixel the interval of depth counts that lies in range and the interval whose point
/// can lie in the crop box (the ray's slab intersection with the box), so a pixel that cannot
/// land in the box costs a few integer compares. The tables are rebuilt when the camera's
/// size, intrinsics, pose or range, or the depth unit, change. Output identical to deproject().
class Deprojector {
 public:
  explicit Deprojector(const Eigen::AlignedBox3d& crop) : crop_(crop) {}
  /// `storage`: a cloud whose capacity is reused for the output (its points are discarded).
  CameraCloud operator()(const DepthImage& image, const PinholeCamera& camera, Cloud&& storage = {});
  int rebuilds() const { return rebuilds_; }  ///< how often the tables were (re)computed

 private:
  struct Limits {
    std::uint16_t range_lo, range_hi;  ///< counts in [min_range, max_range]
    std::uint16_t crop_lo, crop_hi;    ///< counts that may land in the crop box (one count of slack)
  };
  bool current(const DepthImage& image, const PinholeCamera& camera) const;
  void build(const DepthImage& image, const PinholeCamera& camera);

  Eigen::AlignedBox3d crop_;
  PinholeCamera camera_;
  double unit_ = 0;
  std::vector<Limits> limits_;
  std::vector<Eigen::Vector3d> column_, row_;
  int rebuilds_ = 0;
};

/// The same for a recorded scan given as camera-frame points (organised or not):
/// non-finite points and points whose distance from the camera is out of range are dropped;
/// intrinsics are unused.
CameraCloud cameraPointsToCell(const Cloud& camera_points, const PinholeCamera& camera,
                               const Eigen::AlignedBox3d& crop);

}  // namespace depowder::perception
