// A virtual depth camera (an Intel RealSense L515, REFERENCE.md): pinhole model,
// range limits, and the depth artefacts the simulator adds. Kept free of LCM: the
// executable converts a DepthImage to depth_image_t.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder::sim {

/// Depth artefacts of an L515-like LiDAR. Defaults equal node::CameraNoise.
struct DepthNoise {
  double sigma_base = 0.0010;       ///< m, range sigma at zero range
  double sigma_per_m = 0.0025;      ///< m of range sigma added per metre of range
  double flying_pixel_prob = 0.3;   ///< chance that a depth-edge pixel returns a mixed depth
  double flying_edge = 0.01;        ///< m, a 4-neighbour this much nearer/farther makes a pixel a depth-edge pixel
  double grazing_dropout_deg = 78;  ///< deg of incidence beyond which drop-out ramps from 0 (here) to 1 (at 90)
  double dropout_prob = 0.002;      ///< random drop-out probability per pixel
};

struct CameraModel {
  std::string name = "CAM";               ///< DEPTH_<name> in the executable
  int width = 320;                        ///< pixels (L515: 320x240, 640x480, 1024x768)
  int height = 240;                       ///< pixels
  double fx = 228.5;                      ///< pixels (u = fx x / z + cx)
  double fy = 230.5;                      ///< pixels
  double cx = 159.5;                      ///< pixels; pixel (i, j) has its centre at u = i, v = j
  double cy = 119.5;                      ///< pixels
  double min_range = 0.25;                ///< m, nearer returns are invalid (L515: 0.25)
  double max_range = 9.0;                 ///< m, farther returns are invalid (L515: 9)
  double rate_hz = 30;                    ///< frames per second (L515: 30)
  Pose T_cell_camera = Pose::Identity();  ///< camera frame: x right, y down, z forward (optical axis)
  /// The pose its frames carry when it is not the one it renders from (sim.camera_truth: a camera
  /// knocked or measured wrongly); unset: T_cell_camera.
  std::optional<Pose> T_cell_camera_claimed;
  DepthNoise noise;

  /// The pose its frames carry: the claimed one where there is one.
  Pose framePose() const { return T_cell_camera_claimed.value_or(T_cell_camera); }

  /// Intrinsics from the field of view, as node::CameraConfig's (focalLength, cx = (w-1)/2).
  static CameraModel fromFov(std::string name, int width, int height, double fov_h_deg, double fov_v_deg,
                             const Pose& T_cell_camera);
};

/// One rendered frame. Depth is along the optical axis (z), like depth_image_t.
struct DepthImage {
  std::string camera;
  std::int64_t frame = 0;  ///< per-camera counter
  double time = 0;         ///< s of simulated time when rendered
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< pixels
  double min_range = 0, max_range = 0;    ///< m
  double depth_unit = 0.00025;            ///< m per count (L515: 0.25 mm)
  Pose T_cell_camera = Pose::Identity();
  std::vector<std::uint16_t> depth;  ///< row-major, counts of depth_unit, 0 = no return

  /// Depth of pixel (u, v) in metres, 0 for no return.
  double metres(int u, int v) const { return depth[static_cast<std::size_t>(v) * width + u] * depth_unit; }
  /// Camera-frame point of pixel (u, v) (meaningless where metres() is 0).
  Point point(int u, int v) const;
  /// Every valid pixel as a point in the cell frame (tests and tools).
  Cloud cellCloud() const;
};

}  // namespace depowder::sim
