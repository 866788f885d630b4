// LCM messages as they arrive (a corrupt or hostile datagram on the bus): each type's decode()
// must fail cleanly or give a message, and the converters the processes run on a decoded
// message (poses, clouds, depth frames through the camera proxy's deprojection) must reject
// what is wrong with an error, never crash. The first byte picks the type.
#include <cstdlib>
#include <iterator>
#include <string>

#include "depowder/depth_image_t.hpp"
#include "depowder/estop_t.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/perception/depth.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/sim_truth_t.hpp"
#include "depth_msg.hpp"
#include "fuzz.hpp"

using namespace depowder;
using fuzz::decoded;

namespace {

template <class T>
void decodeOnly(const std::uint8_t* data, std::size_t size) {
  T msg;
  decoded(msg, data, size);
}

void checkCloud(const std::uint8_t* data, std::size_t size) {
  point_cloud_t msg;
  std::string why;
  if (decoded(msg, data, size) && !node::decodeCloud(msg, &why) && why.empty()) std::abort();
}

void checkDepth(const std::uint8_t* data, std::size_t size) {
  depth_image_t msg;
  perception::DepthImage image;
  perception::PinholeCamera camera;
  if (!decoded(msg, data, size) || !perception::fromMsg(msg, image, camera).ok()) return;
  const Eigen::AlignedBox3d crop(Eigen::Vector3d(-0.5, -0.5, 0), Eigen::Vector3d(0.5, 0.5, 0.5));
  const perception::CameraCloud once = perception::deproject(image, camera, crop);
  perception::Deprojector stream(crop);
  if (stream(image, camera).points.size() != once.points.size()) std::abort();
}

void checkPartPose(const std::uint8_t* data, std::size_t size) {
  part_pose_t msg;
  if (!decoded(msg, data, size)) return;
  std::string why;
  if (const auto pose = node::fromMsg(msg.T_cell_part, &why)) {
    if (!pose->matrix().allFinite()) std::abort();
  } else if (why.empty()) {
    std::abort();
  }
}

using Check = void (*)(const std::uint8_t*, std::size_t);
const Check kChecks[] = {checkCloud,
                         checkDepth,
                         checkPartPose,
                         decodeOnly<nozzle_plan_t>,
                         decodeOnly<robot_state_t>,
                         decodeOnly<progress_t>,
                         decodeOnly<heartbeat_t>,
                         decodeOnly<estop_t>,
                         decodeOnly<sim_truth_t>};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size >= 1) kChecks[data[0] % std::size(kChecks)](data + 1, size - 1);
  return 0;
}
