// depowder-camera's logic behind the bus, on messages that decode but say anything: a sequence
// of DEPTH frames (any camera, size, time or pose) and ROBOT_STATE messages goes to the camera
// proxy of the static cube cell (config/scenarios/static.yaml) as depowder-camera hands them
// over, with a poll after each, 33 ms apart. Nothing may crash, every frame offered is counted,
// and every point published is finite and inside the box's crop.
// Input: records of [kind byte][length, 2 bytes little-endian][the LCM message].
#include <algorithm>
#include <cstdlib>

#include "camera_options.hpp"
#include "depowder/depth_image_t.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/perception/camera_proxy.hpp"
#include "depowder/robot_state_t.hpp"
#include "depth_msg.hpp"
#include "fuzz.hpp"

using namespace depowder;
using namespace depowder::perception;
using fuzz::decoded;

namespace {

struct Cell {
  CameraNodeOptions options =
      readCameraOptions(node::loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/scenarios/static.yaml"));
  std::vector<std::string> cameras;
  Eigen::AlignedBox3d crop = cropBox(options.cell.box.size, options.perception.crop_margin);
  Cell() {
    for (const auto& c : options.cell.cameras) cameras.push_back(c.name);
  }
};

void check(const CellCloud& cloud, const Eigen::AlignedBox3d& crop) {
  if (cloud.on_nozzle > cloud.points_in || cloud.points.size() > cloud.points_in) std::abort();
  const Eigen::AlignedBox3d slack(crop.min().array() - 1e-9, crop.max().array() + 1e-9);
  for (const Point& p : cloud.points)
    if (!p.allFinite() || !slack.contains(p)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Cell c;
  CameraProxy proxy(c.options.perception, c.options.cell.box.size, c.cameras);
  std::int64_t now_us = 1'000'000, offered = 0;
  fuzz::forEachRecord(data, size, 2, [&](int kind, const std::uint8_t* msg, std::size_t n) {
    now_us += 33'000;
    if (kind == 0) {
      depth_image_t m;
      if (!decoded(m, msg, n)) return;
      DepthImage image;
      PinholeCamera camera;
      const FrameError e = fromMsg(m, image, camera);
      if (e.ok())
        proxy.addDepth(image, camera, now_us);
      else
        proxy.reject(e);
      ++offered;
    } else {
      robot_state_t m;
      if (!decoded(m, msg, n) || !m.measured) return;
      if (const std::optional<Pose> T = node::fromMsg(m.T_cell_nozzle)) proxy.addNozzlePose(m.utime, *T);
    }
    for (const CellCloud& cloud : proxy.poll(now_us)) check(cloud, c.crop);
  });
  if (proxy.counters().frames_in != offered) std::abort();
  return 0;
}
