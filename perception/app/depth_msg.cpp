#include "depth_msg.hpp"

#include <cstring>

#include "depowder/node/convert.hpp"

namespace depowder::perception {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "depth_image_t data is little-endian; this host is not");

FrameError fromMsg(const depth_image_t& msg, DepthImage& image, PinholeCamera& camera) {
  camera.name = msg.camera;
  camera.width = msg.width;
  camera.height = msg.height;
  camera.fx = msg.fx;
  camera.fy = msg.fy;
  camera.cx = msg.cx;
  camera.cy = msg.cy;
  camera.min_range = msg.min_range;
  camera.max_range = msg.max_range;
  std::string why;
  const auto pose = node::fromMsg(msg.T_cell_camera, &why);
  if (!pose) return {FrameStatus::kBadHeader, "camera '" + msg.camera + "': T_cell_camera: " + why};
  camera.T_cell_camera = *pose;
  image.utime = msg.utime;
  image.frame = msg.frame;
  image.width = msg.width;
  image.height = msg.height;
  image.depth_unit = msg.depth_unit;
  const std::size_t bytes = msg.data.size();
  if (bytes % 2 != 0 || static_cast<std::int64_t>(bytes) != msg.num_bytes)
    return {FrameStatus::kSizeMismatch, "camera '" + msg.camera + "': frame " + std::to_string(msg.frame) +
                                            " has num_bytes " + std::to_string(msg.num_bytes) +
                                            ", which is odd or not its data length"};
  image.depth.resize(bytes / 2);
  if (bytes > 0) std::memcpy(image.depth.data(), msg.data.data(), bytes);
  return {};
}

depth_image_t toMsg(const DepthImage& image, const PinholeCamera& camera) {
  depth_image_t msg;
  msg.utime = image.utime;
  msg.frame = image.frame;
  msg.camera = camera.name;
  msg.width = image.width;
  msg.height = image.height;
  msg.fx = camera.fx;
  msg.fy = camera.fy;
  msg.cx = camera.cx;
  msg.cy = camera.cy;
  msg.min_range = static_cast<float>(camera.min_range);
  msg.max_range = static_cast<float>(camera.max_range);
  msg.T_cell_camera = node::toMsg(camera.T_cell_camera);
  msg.depth_unit = static_cast<float>(image.depth_unit);
  msg.num_bytes = static_cast<std::int32_t>(image.depth.size() * 2);
  msg.data.resize(image.depth.size() * 2);
  if (!image.depth.empty()) std::memcpy(msg.data.data(), image.depth.data(), msg.data.size());
  return msg;
}

}  // namespace depowder::perception
