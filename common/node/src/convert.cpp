#include "depowder/node/convert.hpp"

#include <chrono>
#include <cmath>
#include <limits>

namespace depowder::node {

pose_t toMsg(const Pose& pose) {
  pose_t msg;
  const Eigen::Quaterniond q(pose.linear());
  for (int i = 0; i < 3; ++i) msg.position[i] = pose.translation()[i];
  msg.orientation[0] = q.w();
  msg.orientation[1] = q.x();
  msg.orientation[2] = q.y();
  msg.orientation[3] = q.z();
  return msg;
}

std::optional<Pose> fromMsg(const pose_t& msg, std::string* why) {
  const Eigen::Vector3d t(msg.position[0], msg.position[1], msg.position[2]);
  const Eigen::Quaterniond q(msg.orientation[0], msg.orientation[1], msg.orientation[2], msg.orientation[3]);
  if (!t.allFinite() || !q.coeffs().allFinite()) {
    if (why) *why = "pose has NaN or infinite values";
    return std::nullopt;
  }
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    if (why) *why = "pose quaternion is not unit (norm " + std::to_string(q.norm()) + ")";
    return std::nullopt;
  }
  return makePose(t, q);
}

point_cloud_t encodeCloud(const Cloud& cloud, std::int64_t utime, double resolution, int* dropped) {
  point_cloud_t msg;
  msg.utime = utime;
  msg.seq = 0;
  msg.frame = "cell";
  msg.resolution = static_cast<float>(resolution);
  Eigen::AlignedBox3d box;
  for (const Point& p : cloud)
    if (p.allFinite()) box.extend(p);
  const Eigen::Vector3d origin = box.isEmpty() ? Eigen::Vector3d::Zero().eval() : box.center().eval();
  for (int i = 0; i < 3; ++i) msg.origin[i] = static_cast<float>(origin[i]);
  const Eigen::Vector3d o(msg.origin[0], msg.origin[1], msg.origin[2]);  // as the receiver sees it
  const double limit = std::numeric_limits<std::int16_t>::max();
  int lost = 0;
  msg.xyz.reserve(cloud.size());
  for (const Point& p : cloud) {
    const Eigen::Vector3d q = ((p - o) / msg.resolution).array().round();
    if (!q.allFinite() || q.cwiseAbs().maxCoeff() > limit) {
      ++lost;
      continue;
    }
    msg.xyz.push_back(
        {static_cast<std::int16_t>(q.x()), static_cast<std::int16_t>(q.y()), static_cast<std::int16_t>(q.z())});
  }
  msg.num_points = static_cast<std::int32_t>(msg.xyz.size());
  msg.num_sources = 0;
  if (dropped) *dropped = lost;
  return msg;
}

std::optional<Cloud> decodeCloud(const point_cloud_t& msg, std::string* why) {
  const Eigen::Vector3d o(msg.origin[0], msg.origin[1], msg.origin[2]);
  if (!o.allFinite() || !std::isfinite(msg.resolution) || msg.resolution <= 0) {
    if (why) *why = "point cloud has an invalid origin or resolution";
    return std::nullopt;
  }
  Cloud cloud;
  cloud.reserve(msg.xyz.size());
  for (const auto& q : msg.xyz) cloud.push_back(o + msg.resolution * Eigen::Vector3d(q[0], q[1], q[2]));
  return cloud;
}

std::int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::int64_t steadyUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace depowder::node
