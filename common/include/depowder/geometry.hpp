// Poses, points and the small geometric helpers every module shares.
#pragma once

#include <Eigen/Geometry>
#include <vector>

namespace depowder {

/// One pose type across the code base: T_target_source maps source-frame points into target.
using Pose = Eigen::Isometry3d;
using Point = Eigen::Vector3d;
using Cloud = std::vector<Point>;

/// Angle of the relative rotation a^T b, radians in [0, pi].
double rotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

/// The turn about the vertical (z) of a rotation, radians in (-pi, pi]: the angle of its upper-left
/// 2x2 block's nearest rotation (exact for a rotation about z; a tip does not change it much).
double turnAboutVertical(const Eigen::Matrix3d& R);

/// Angle of the relative rotation of two poses, degrees in [0, 180].
double rotationDistanceDeg(const Pose& a, const Pose& b);

/// Translation distance |a.t - b.t|, metres.
double translationDistance(const Pose& a, const Pose& b);

/// True if every entry is finite, the rotation is orthonormal with det +1 (within tol)
/// and the last row is (0 0 0 1).
bool isValidPose(const Pose& pose, double tolerance = 1e-6);

/// Camera pose at `position` looking at `target` (z forward, image x horizontal, y down).
Pose lookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target);

/// The frame of the segment p0 -> p1: origin at its middle, z along it (no turn for a segment of
/// no length). FCL's capsules and cylinders are centred on their z axis, so this places one.
Pose segmentFrame(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1);

/// Pose from translation (m) and quaternion (w, x, y, z); the quaternion is normalised.
Pose makePose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q);

/// Pose from translation (m) and roll/pitch/yaw (rad, applied as Rz(yaw) Ry(pitch) Rx(roll)).
Pose makePoseRpy(const Eigen::Vector3d& t, double roll, double pitch, double yaw);

/// Axis-aligned bounds of a cloud.
Eigen::AlignedBox3d bounds(const Cloud& cloud);

/// Axis-aligned bounds of `box` posed by T (its eight corners moved).
Eigen::AlignedBox3d bounds(const Eigen::AlignedBox3d& box, const Pose& T);

/// A pinhole camera's focal length, pixels, for `pixels` across a field of view of `fov_deg`:
/// pixels / 2 / tan(fov / 2). The principal point of such a camera is at (pixels - 1) / 2.
double focalLength(int pixels, double fov_deg);

/// p -> T * p for every point.
Cloud transformed(const Cloud& cloud, const Pose& T);

/// Rotates normals by T's rotation.
Cloud rotated(const Cloud& normals, const Pose& T);

/// Whether p, in the nozzle's frame (tip at the origin, body along -z), lies on the nozzle's body
/// (`length` m of it above the tip, `radius` m) grown by `along` m past both its ends and by
/// `around` m round its side (strict bounds).
bool onNozzleBody(const Point& p_nozzle, double length, double radius, double along, double around);

/// One cylinder of the end effector's body, m. The body is a list of them on the tool axis, one
/// after another from the flange towards the nozzle tip (robot.effector).
struct EffectorSection {
  double radius = 0, length = 0;
};
/// The authors' vacuum end effector (data/robot/vacuum_end_effector.stl, 12.9 cm long): a plate on
/// the flange 44.5 mm in radius and 8 mm thick, then a body 28.6 mm in radius.
std::vector<EffectorSection> vacuumEffector();

/// One section of the end effector placed in the flange frame: a cylinder on the line from the
/// flange to the nozzle tip (robot.tool_offset's translation).
struct EffectorBody {
  Pose T_flange_body = Pose::Identity();  ///< centred (as FCL's cylinders); z along the line, towards the tip
  double radius = 0, length = 0;          ///< m
  /// The frame of its end nearest the tip, where the section runs from z = -length to 0 (as the
  /// nozzle's body does in onNozzleBody and cylinderMesh).
  Pose T_flange_end() const;
};
/// The sections placed one after another from the flange along the line to the nozzle tip at
/// T_flange_nozzle and cut at the tip; those left with no length or radius are left out. The planner, the simulated
/// arm, the camera proxy's self-filter and the viewer all place the end effector with it.
std::vector<EffectorBody> effectorBodies(const std::vector<EffectorSection>& sections, const Pose& T_flange_nozzle);

}  // namespace depowder
