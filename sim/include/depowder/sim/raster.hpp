// A z-buffer rasteriser for depth cameras. At these sizes (tens of thousands of
// triangles, most of them a few pixels) rasterising beats ray casting by far: a
// triangle costs a projection and a few edge-function tests, while a ray cast costs
// a BVH walk per pixel (sim/README.md has the figures). Depth is interpolated as
// 1/z, which is exact for planar triangles under perspective.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/sim/camera.hpp"

namespace depowder::sim {

enum class Culling {
  kNone,       ///< draw both sides (any mesh, whatever its winding)
  kBackFaces,  ///< skip triangles facing away from the camera (closed, outward-wound meshes)
};

class DepthRasterizer {
 public:
  /// Sizes the buffers for `camera` and clears them. Call once per frame.
  void begin(const CameraModel& camera);

  /// Draws a mesh whose vertices are in its own frame, placed at T_cell_object.
  void drawMesh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                const Pose& T_cell_object, Culling culling);
  /// Draws cell-frame vertices with a flat index list (3 per triangle).
  void drawCellTriangles(const std::vector<Eigen::Vector3f>& vertices, const std::vector<std::uint32_t>& indices,
                         Culling culling);

  int width() const { return width_; }
  int height() const { return height_; }
  /// z (m) of the nearest surface at pixel (u, v), 0 if nothing was drawn there.
  float depth(int u, int v) const {
    const float w = inv_depth_[static_cast<std::size_t>(v) * width_ + u];
    return w > 0 ? 1.0f / w : 0.0f;
  }
  /// Unit normal (camera frame) of the surface seen at (u, v); undefined where depth is 0.
  Eigen::Vector3f normal(int u, int v) const { return normals_[ids_[static_cast<std::size_t>(v) * width_ + u]]; }
  const std::vector<float>& inverseDepth() const { return inv_depth_; }
  /// Per pixel, range / z along its ray (|(x/z, y/z, 1)|); computed when the intrinsics change.
  const std::vector<float>& rangePerDepth() const { return range_per_depth_; }

 private:
  void drawCameraFrame(const std::vector<Eigen::Vector3f>& cam, const std::uint32_t* indices, std::size_t count,
                       Culling culling);
  void rasterize(const Eigen::Vector3f* v, int normal_id);  ///< one triangle in front of the near plane

  int width_ = 0, height_ = 0;
  float fx_ = 1, fy_ = 1, cx_ = 0, cy_ = 0;
  Pose T_camera_cell_ = Pose::Identity();
  std::vector<float> inv_depth_;          ///< 1/z, 0 = empty
  std::vector<std::int32_t> ids_;         ///< index into normals_
  std::vector<Eigen::Vector3f> normals_;  ///< one per drawn triangle, camera frame
  std::vector<float> range_per_depth_;
  double ray_fx_ = 0, ray_fy_ = 0, ray_cx_ = 0, ray_cy_ = 0;  ///< intrinsics range_per_depth_ was made for
  std::vector<Eigen::Vector3f> scratch_;                      ///< camera-frame vertices of the current mesh
  std::vector<std::uint32_t> index_scratch_;
};

}  // namespace depowder::sim
