#include "depowder/geometry.hpp"

#include <algorithm>
#include <cmath>

namespace depowder {

double rotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const double c = ((a.transpose() * b).trace() - 1.0) / 2.0;
  return std::acos(std::clamp(c, -1.0, 1.0));
}

double turnAboutVertical(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0) - R(0, 1), R(0, 0) + R(1, 1)); }

double rotationDistanceDeg(const Pose& a, const Pose& b) {
  return rotationAngle(a.linear(), b.linear()) * 180.0 / M_PI;
}

double translationDistance(const Pose& a, const Pose& b) { return (a.translation() - b.translation()).norm(); }

bool isValidPose(const Pose& pose, double tolerance) {
  const Eigen::Matrix4d& m = pose.matrix();
  if (!m.allFinite()) return false;
  if (!m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), tolerance)) return false;
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < tolerance &&
         std::abs(r.determinant() - 1.0) < tolerance;
}

Pose lookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - position).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();  // looking straight down or up
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Pose T = Pose::Identity();
  T.linear() << x, y, z;
  T.translation() = position;
  return T;
}

Pose segmentFrame(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1) {
  Pose T = Pose::Identity();
  T.translation() = 0.5 * (p0 + p1);
  const Eigen::Vector3d d = p1 - p0;
  if (d.norm() > 1e-12)
    T.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), d.normalized()).toRotationMatrix();
  return T;
}

Pose makePose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Pose pose = Pose::Identity();
  pose.linear() = q.normalized().toRotationMatrix();
  pose.translation() = t;
  return pose;
}

Pose makePoseRpy(const Eigen::Vector3d& t, double roll, double pitch, double yaw) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  return makePose(t, q);
}

Eigen::AlignedBox3d bounds(const Cloud& cloud) {
  Eigen::AlignedBox3d box;
  for (const Point& p : cloud) box.extend(p);
  return box;
}

Eigen::AlignedBox3d bounds(const Eigen::AlignedBox3d& box, const Pose& T) {
  Eigen::AlignedBox3d out;
  for (int c = 0; c < 8; ++c) out.extend(T * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
  return out;
}

Cloud transformed(const Cloud& cloud, const Pose& T) {
  Cloud out(cloud.size());
  std::transform(cloud.begin(), cloud.end(), out.begin(), [&](const Point& p) { return T * p; });
  return out;
}

Cloud rotated(const Cloud& normals, const Pose& T) {
  Cloud out(normals.size());
  const Eigen::Matrix3d R = T.linear();
  std::transform(normals.begin(), normals.end(), out.begin(), [&](const Point& n) { return R * n; });
  return out;
}

double focalLength(int pixels, double fov_deg) { return 0.5 * pixels / std::tan(0.5 * fov_deg * M_PI / 180.0); }

bool onNozzleBody(const Point& p, double length, double radius, double along, double around) {
  const double r = radius + around;
  return p.z() < along && p.z() > -(length + along) && p.head<2>().squaredNorm() < r * r;
}

std::vector<EffectorSection> vacuumEffector() { return {{0.0445, 0.008}, {0.0286, 0.121}}; }

Pose EffectorBody::T_flange_end() const {
  Pose T_body_end = Pose::Identity();
  T_body_end.translation().z() = 0.5 * length;
  return T_flange_body * T_body_end;
}

std::vector<EffectorBody> effectorBodies(const std::vector<EffectorSection>& sections, const Pose& T_flange_nozzle) {
  const Eigen::Vector3d tip = T_flange_nozzle.translation();
  const double reach = tip.norm();
  std::vector<EffectorBody> bodies;
  if (reach <= 0) return bodies;  // a tip on the flange leaves no room
  const Eigen::Vector3d axis = tip / reach;
  double from = 0;
  for (const EffectorSection& s : sections) {
    const double to = std::min(from + s.length, reach);
    if (s.radius > 0 && to > from) bodies.push_back({segmentFrame(from * axis, to * axis), s.radius, to - from});
    from += s.length;
  }
  return bodies;
}

}  // namespace depowder
