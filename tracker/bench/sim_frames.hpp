// Frames of the simulator (sim/: powder height field, solid parts, the cell's two L515 cameras
// with their noise, flying pixels and drop-outs) for depowder-bench, merged, cropped to the box
// and voxel-downsampled at 5 mm as the camera proxy publishes POINTS.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"

namespace depowder::tracker::bench {

class SimFrames {
 public:
  /// Cameras (intrinsics, extrinsics, noise) and the box from the cell YAML at `cell_path`.
  explicit SimFrames(const std::string& cell_path);
  ~SimFrames();

  /// The part dug to `visibility` (the simulator's true Eq. 2) at truth[0], then set to each
  /// pose of `truth` in turn: one cloud per pose.
  std::vector<Cloud> render(const std::string& name, const Mesh& mesh, const std::vector<Pose>& truth,
                            double visibility, std::uint32_t seed) const;

  /// The cameras' positions, cell frame.
  std::vector<Point> viewpoints() const;
  const std::string& cellFile() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace depowder::tracker::bench
