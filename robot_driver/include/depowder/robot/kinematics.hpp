// DENSO VS-6577 kinematics (REFERENCE.md joint chain): forward and inverse
// kinematics of the nozzle, link poses for collision checking. Shared by the
// driver and the planner.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"

namespace depowder::robot {

using Joints = std::array<double, 6>;  ///< J1..J6, rad

struct ArmConfig {
  Pose T_cell_base = Pose::Identity();      ///< robot base in the cell frame
  Pose T_flange_nozzle = Pose::Identity();  ///< tool offset: nozzle tip in the flange frame (z = spray direction)
  Joints q_min{-2.96706, -1.745329, -2.076942, -3.316126, -2.094395, -6.283185};  ///< rad
  Joints q_max{2.96706, 2.356194, 2.949606, 3.316126, 2.094395, 6.283185};        ///< rad
  Joints qd_max{3.927, 2.618, 2.858, 3.927, 3.022, 6.283};  ///< rad/s (VS060 figures: order of magnitude only)
  Joints qdd_max{8, 8, 8, 12, 12, 20};                      ///< rad/s^2
  Joints q_home{0, 0.3, 1.6, 0, 1.2, 0};                    ///< rad, a safe pose above the box
  Joints ik_weights{1, 1, 1, 0.5, 0.5, 0.3};  ///< weights of the joint distance that picks the IK solution
  /// The end effector's body: cylinders from the flange towards the nozzle tip (the authors' vacuum
  /// end effector), placed by effectorBodies(effector, T_flange_nozzle). The nozzle tube (the
  /// planner's nozzle cylinder) runs on to the tip.
  std::vector<EffectorSection> effector = vacuumEffector();
};

/// Kinematic constants of the chain (REFERENCE.md), metres.
struct Vs6577 {
  static constexpr double kBaseToJ2Z = 0.335;      ///< J1 -> J2 along z
  static constexpr double kBaseToJ2X = 0.075;      ///< J1 -> J2 along x
  static constexpr double kUpperArm = 0.365;       ///< J2 -> J3 along z
  static constexpr double kForearmX = -0.090;      ///< J3 -> J5 along x (kinematic, see REFERENCE.md)
  static constexpr double kForearmZ = 0.405;       ///< J3 -> J5 along z
  static constexpr double kJ3ToJ4Z = -0.700;       ///< URDF frame of J4 (mesh origin artefact)
  static constexpr double kJ4ToJ5Z = 1.105;        ///< URDF frame of J5
  static constexpr double kWristToFlange = 0.080;  ///< J5 -> flange along z
};

/// T_base_flange for joint angles q (no limits applied).
Pose forwardFlange(const Joints& q);
/// T_cell_nozzle for q with the arm's base pose and tool offset.
Pose forwardNozzle(const ArmConfig& arm, const Joints& q);
/// Poses in the base frame of base_link, J1..J6 link frames (7 poses), for collision geometry.
/// Link frames are those of the public URDF, so its meshes can be drawn in them.
std::vector<Pose> linkPoses(const Joints& q);

bool withinLimits(const ArmConfig& arm, const Joints& q);

/// Joint angles that put the nozzle at T_cell_nozzle, within limits, nearest `seed`
/// (weighted joint distance); nullopt if unreachable.
std::optional<Joints> inverseNozzle(const ArmConfig& arm, const Pose& T_cell_nozzle, const Joints& seed);

/// Every distinct IK solution for the flange pose T_base_flange (up to 8 branches: shoulder
/// front/back, elbow up/down, wrist flip), each shifted by multiples of 2 pi to lie nearest `seed`
/// within limits; branches outside the limits are left out. Unsorted.
std::vector<Joints> inverseFlangeAll(const ArmConfig& arm, const Pose& T_base_flange, const Joints& seed);

/// sum_i w_i (a_i - b_i)^2 with the arm's IK weights.
double jointDistance(const ArmConfig& arm, const Joints& a, const Joints& b);

/// Geometric Jacobian of the flange origin in the base frame (inverseNozzle's refinement):
/// rows 0..2 linear (m/rad), rows 3..5 angular (rad/rad).
Eigen::Matrix<double, 6, 6> jacobianFlange(const Joints& q);

/// A capsule (segment p0-p1 swept by a sphere of `radius`) fixed to one link frame.
struct LinkCapsule {
  int link = 0;      ///< index into linkPoses(): 0 base_link, 1..6 J1..J6 (J6 carries the tool)
  std::string name;  ///< e.g. "J4.forearm"
  Eigen::Vector3d p0 = Eigen::Vector3d::Zero();  ///< m, in the link frame
  Eigen::Vector3d p1 = Eigen::Vector3d::Zero();  ///< m, in the link frame
  double radius = 0.0;                           ///< m
};

/// Simple collision geometry of the arm: capsules in the link frames, fitted to enclose the
/// public URDF meshes. World pose of capsule c: T_cell_base * linkPoses(q)[c.link].
std::vector<LinkCapsule> linkCapsules();

}  // namespace depowder::robot
