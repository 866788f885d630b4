#include "sim_frames.hpp"

#include "depowder/node/cell.hpp"
#include "depowder/perception/config.hpp"
#include "depowder/perception/depth.hpp"
#include "depowder/perception/voxel_grid.hpp"
#include "depowder/sim/world.hpp"
#include "setup.hpp"  // sim::cameraModelOf

namespace depowder::tracker::bench {

struct SimFrames::Impl {
  std::string file;
  std::vector<sim::CameraModel> cameras;
  sim::BoxGeometry box;
  Eigen::AlignedBox3d crop;
  perception::PerceptionConfig proxy;  ///< the camera proxy's defaults: crop margin, voxel, outlier removal
};

SimFrames::SimFrames(const std::string& cell_path) : impl_(std::make_unique<Impl>()) {
  const node::CellConfig cell = node::loadCell(cell_path);
  impl_->file = cell.file;
  for (const node::CameraConfig& c : cell.cameras) impl_->cameras.push_back(sim::cameraModelOf(c));
  impl_->box = {cell.box.size, cell.box.wall};
  // The camera proxy's crop: the box interior plus its margin (walls and table left out).
  impl_->crop = perception::cropBox(cell.box.size, impl_->proxy.crop_margin);
}

SimFrames::~SimFrames() = default;

std::vector<Cloud> SimFrames::render(const std::string& name, const Mesh& mesh, const std::vector<Pose>& truth,
                                     double visibility, std::uint32_t seed) const {
  sim::World world(sim::SimConfig{}, impl_->box, {{name, mesh, truth.front(), 1000}}, impl_->cameras, seed);
  world.removeNozzle();
  world.digToVisibility(0, visibility);
  std::vector<Cloud> frames;
  // Merged, cropped, voxelled, isolated voxels (flying pixels) removed: the camera proxy's
  // VoxelGrid with its default settings.
  perception::VoxelGrid grid(impl_->crop, impl_->proxy.voxel_leaf);
  for (const Pose& T : truth) {
    world.setPartPose(0, T);
    for (std::size_t c = 0; c < impl_->cameras.size(); ++c) grid.add(world.render(c).cellCloud());
    frames.push_back(grid.extract(impl_->proxy.outlier_min_neighbours).points);
  }
  return frames;
}

std::vector<Point> SimFrames::viewpoints() const {
  std::vector<Point> out;
  for (const sim::CameraModel& c : impl_->cameras) out.push_back(c.T_cell_camera.translation());
  return out;
}

const std::string& SimFrames::cellFile() const { return impl_->file; }

}  // namespace depowder::tracker::bench
