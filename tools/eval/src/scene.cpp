#include "depowder/eval/scene.hpp"

#include <algorithm>
#include <cmath>

#include "depowder/parts.hpp"

namespace depowder::eval {

double paperXi(const std::string& part) { return part == "propeller" || part == "pipe" ? 0.008 : 0.010; }

EvalPart defaultPart(const std::string& name) { return {name, parts::byName(name), paperXi(name)}; }

Pose placePart(const Mesh& mesh, double yaw, const Eigen::Vector2d& xy, double bottom_z) {
  Pose T = makePoseRpy(Eigen::Vector3d::Zero(), 0, 0, yaw);
  const Eigen::AlignedBox3d b = bounds(transformed(mesh, T));
  T.translation() = Eigen::Vector3d(xy.x() - b.center().x(), xy.y() - b.center().y(), bottom_z - b.min().z());
  return T;
}

std::vector<Point> viewpoints(const std::vector<sim::CameraModel>& cameras) {
  std::vector<Point> out;
  for (const sim::CameraModel& c : cameras) out.push_back(c.framePose().translation());
  return out;
}

ProxyInput toProxyInput(const sim::DepthImage& frame) {
  ProxyInput in;
  in.image.utime = std::llround(frame.time * 1e6);
  in.image.frame = frame.frame;
  in.image.width = frame.width;
  in.image.height = frame.height;
  in.image.depth_unit = frame.depth_unit;
  in.image.depth = frame.depth;
  in.camera.name = frame.camera;
  in.camera.width = frame.width;
  in.camera.height = frame.height;
  in.camera.fx = frame.fx;
  in.camera.fy = frame.fy;
  in.camera.cx = frame.cx;
  in.camera.cy = frame.cy;
  in.camera.min_range = frame.min_range;
  in.camera.max_range = frame.max_range;
  in.camera.T_cell_camera = frame.T_cell_camera;
  return in;
}

namespace {
std::vector<std::string> cameraNames(const std::vector<sim::CameraModel>& cameras) {
  std::vector<std::string> names;
  for (const sim::CameraModel& c : cameras) names.push_back(c.name);
  return names;
}
}  // namespace

FrameSource::FrameSource(const EvalCell& cell)
    : proxy_(cell.perception, cell.box.size, cameraNames(cell.cameras)),
      max_wait_us_(std::llround(cell.perception.merger.max_wait * 1e6)) {}

Cloud FrameSource::capture(sim::World& world, const Pose* T_cell_nozzle) {
  std::int64_t utime = 0;
  for (std::size_t c = 0; c < world.cameras().size(); ++c) {
    const ProxyInput in = toProxyInput(world.render(c));  // the pose the frame says (a claimed one too)
    utime = in.image.utime;
    proxy_.addDepth(in.image, in.camera, utime);  // arrival = capture time: no transport delay in process
  }
  if (T_cell_nozzle != nullptr) proxy_.addNozzlePose(utime, *T_cell_nozzle);
  // Every camera's frame is in: the time step is complete (polling after max_wait releases it
  // even if a camera's frame was rejected, as the camera process would).
  Cloud scan;
  for (perception::CellCloud& cloud : proxy_.poll(utime + max_wait_us_)) scan = std::move(cloud.points);
  return scan;
}

std::uint32_t trialSeed(std::uint32_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  std::uint64_t x = seed;
  for (std::uint64_t v : {a, b, c}) {
    x ^= v + 0x9e3779b97f4a7c15ull + (x << 6) + (x >> 2);
    // splitmix64 finaliser
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    x ^= x >> 31;
  }
  return static_cast<std::uint32_t>(x ^ (x >> 32));
}

PoseError poseError(const Pose& estimate, const Pose& truth) {
  return {rotationAngle(estimate.rotation(), truth.rotation()) * 180.0 / M_PI,
          translationDistance(estimate, truth) * 100.0};
}

double tiltError(const Pose& estimate, const Pose& truth) {
  const double c = estimate.linear().col(2).dot(truth.linear().col(2));
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace depowder::eval
