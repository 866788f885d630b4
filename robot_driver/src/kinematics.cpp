#include "depowder/robot/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace depowder::robot {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;
using C = Vs6577;

Pose translation(double x, double y, double z) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

Pose rotZ(double a) { return Pose(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ())); }
Pose rotY(double a) { return Pose(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY())); }

// The 2pi-shift of `angle` that lies within [lo, hi] nearest to `seed`; nullopt if none does.
std::optional<double> nearestWithin(double angle, double seed, double lo, double hi) {
  constexpr double kSlack = 1e-9;  // accept angles on the limit that rounding pushed just outside
  std::optional<double> best;
  // Move the angle near the seed first, then try the neighbouring turns.
  const double base = angle + kTwoPi * std::round((seed - angle) / kTwoPi);
  for (int k = -2; k <= 2; ++k) {
    double a = base + kTwoPi * k;
    if (a < lo - kSlack || a > hi + kSlack) continue;
    a = std::min(std::max(a, lo), hi);
    if (!best || std::abs(a - seed) < std::abs(*best - seed)) best = a;
  }
  return best;
}

// Pose error (translation, rotation vector) of `T` relative to `target`, both in the same frame.
Eigen::Matrix<double, 6, 1> poseError(const Pose& target, const Pose& T) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = target.translation() - T.translation();
  const Eigen::AngleAxisd aa(target.linear() * T.linear().transpose());
  e.tail<3>() = aa.angle() * aa.axis();
  return e;
}

}  // namespace

std::vector<Pose> linkPoses(const Joints& q) {
  std::vector<Pose> T(7);
  T[0] = Pose::Identity();
  T[1] = T[0] * rotZ(q[0]);
  T[2] = T[1] * translation(C::kBaseToJ2X, 0, C::kBaseToJ2Z) * rotY(q[1]);
  T[3] = T[2] * translation(0, 0, C::kUpperArm) * rotY(q[2]);
  T[4] = T[3] * translation(C::kForearmX, 0, C::kJ3ToJ4Z) * rotZ(q[3]);
  T[5] = T[4] * translation(0, 0, C::kJ4ToJ5Z) * rotY(q[4]);
  T[6] = T[5] * translation(0, 0, C::kWristToFlange) * rotZ(q[5]);
  return T;
}

Pose forwardFlange(const Joints& q) { return linkPoses(q)[6]; }

Pose forwardNozzle(const ArmConfig& arm, const Joints& q) {
  return arm.T_cell_base * forwardFlange(q) * arm.T_flange_nozzle;
}

bool withinLimits(const ArmConfig& arm, const Joints& q) {
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(q[i]) || q[i] < arm.q_min[i] || q[i] > arm.q_max[i]) return false;
  }
  return true;
}

double jointDistance(const ArmConfig& arm, const Joints& a, const Joints& b) {
  double d = 0.0;
  for (int i = 0; i < 6; ++i) d += arm.ik_weights[i] * (a[i] - b[i]) * (a[i] - b[i]);
  return d;
}

std::vector<Joints> inverseFlangeAll(const ArmConfig& arm, const Pose& T_base_flange, const Joints& seed) {
  std::vector<Joints> out;
  const Eigen::Matrix3d R = T_base_flange.linear();
  // Spherical wrist: J4, J5, J6 axes meet at the J5 origin, kWristToFlange behind the flange.
  const Eigen::Vector3d p_wrist = T_base_flange.translation() - C::kWristToFlange * R.col(2);

  // Shoulder: the chain has no sideways offset, so the wrist centre lies in the J1 plane.
  // On the J1 axis (shoulder singularity) J1 is free: keep the seed's.
  const double rho = std::hypot(p_wrist.x(), p_wrist.y());
  const double q1_front = rho < 1e-9 ? seed[0] : std::atan2(p_wrist.y(), p_wrist.x());
  const double q1_candidates[2] = {q1_front, q1_front + kPi};

  // Elbow: a planar two-link arm from J2 with links a (upper arm) and b (J3 -> J5, tilted by phi).
  const double a = C::kUpperArm;
  const double b = std::hypot(C::kForearmX, C::kForearmZ);
  const double phi = std::atan2(-C::kForearmX, C::kForearmZ);

  for (double q1 : q1_candidates) {
    const double x1 = std::cos(q1) * p_wrist.x() + std::sin(q1) * p_wrist.y();
    const double r = x1 - C::kBaseToJ2X;
    const double h = p_wrist.z() - C::kBaseToJ2Z;
    double c_beta = (r * r + h * h - a * a - b * b) / (2 * a * b);
    if (c_beta > 1.0 + 1e-9 || c_beta < -1.0 - 1e-9) continue;  // out of reach
    c_beta = std::min(1.0, std::max(-1.0, c_beta));
    const double beta_abs = std::acos(c_beta);
    for (double beta : {beta_abs, -beta_abs}) {
      // (r, h) = A (sin q2, cos q2) + B (cos q2, -sin q2), angles measured from vertical.
      const double A = a + b * std::cos(beta);
      const double B = b * std::sin(beta);
      const double q2 = std::atan2(r, h) - std::atan2(B, A);
      const double q3 = beta + phi;

      // Wrist: R_3_6 = Rz(q4) Ry(q5) Rz(q6) (ZYZ Euler angles).
      const Eigen::Matrix3d R03 = (rotZ(q1) * rotY(q2 + q3)).linear();
      const Eigen::Matrix3d M = R03.transpose() * R;
      const double s5 = std::hypot(M(0, 2), M(1, 2));
      std::vector<std::array<double, 3>> wrists;
      if (s5 < 1e-9) {
        // Wrist singularity (J5 ~ 0 or pi): only q4 + q6 (or q4 - q6) is defined; keep the seed's q4.
        const double c5 = M(2, 2) > 0 ? 0.0 : kPi;
        const double sum = std::atan2(M(1, 0), M(0, 0));
        const double q4 = seed[3];
        // J5 = pi: R = Rz(q4 - q6) Ry(pi).
        const double q6 = c5 == 0.0 ? sum - q4 : q4 - std::atan2(-M(1, 0), -M(0, 0));
        wrists.push_back({q4, c5, q6});
      } else {
        const double q5 = std::atan2(s5, M(2, 2));
        const double q4 = std::atan2(M(1, 2), M(0, 2));
        const double q6 = std::atan2(M(2, 1), -M(2, 0));
        wrists.push_back({q4, q5, q6});
        wrists.push_back({q4 + kPi, -q5, q6 + kPi});
      }
      for (const auto& w : wrists) {
        const double raw[6] = {q1, q2, q3, w[0], w[1], w[2]};
        Joints q;
        bool ok = true;
        for (int i = 0; i < 6 && ok; ++i) {
          const auto v = nearestWithin(raw[i], seed[i], arm.q_min[i], arm.q_max[i]);
          ok = v.has_value();
          if (ok) q[i] = *v;
        }
        if (ok) out.push_back(q);
      }
    }
  }
  return out;
}

std::optional<Joints> inverseNozzle(const ArmConfig& arm, const Pose& T_cell_nozzle, const Joints& seed) {
  if (!isValidPose(T_cell_nozzle, 1e-6)) return std::nullopt;
  const Pose T_base_flange = arm.T_cell_base.inverse() * T_cell_nozzle * arm.T_flange_nozzle.inverse();
  std::vector<Joints> solutions = inverseFlangeAll(arm, T_base_flange, seed);
  std::optional<Joints> best;
  double best_d = std::numeric_limits<double>::infinity();
  for (Joints& q : solutions) {
    // Newton refinement removes the rounding of the closed form near singular configurations.
    for (int it = 0; it < 3; ++it) {
      const Eigen::Matrix<double, 6, 1> e = poseError(T_base_flange, forwardFlange(q));
      if (e.norm() < 1e-12) break;
      const Eigen::Matrix<double, 6, 6> J = jacobianFlange(q);
      const Eigen::Matrix<double, 6, 6> JJt = J * J.transpose() + 1e-12 * Eigen::Matrix<double, 6, 6>::Identity();
      const Eigen::Matrix<double, 6, 1> dq = J.transpose() * JJt.ldlt().solve(e);
      for (int i = 0; i < 6; ++i) q[i] += dq[i];
    }
    const Eigen::Matrix<double, 6, 1> e = poseError(T_base_flange, forwardFlange(q));
    if (e.head<3>().norm() > 1e-7 || e.tail<3>().norm() > 1e-7) continue;
    for (int i = 0; i < 6; ++i) q[i] = std::min(std::max(q[i], arm.q_min[i]), arm.q_max[i]);
    const double d = jointDistance(arm, q, seed);
    if (d < best_d) {
      best_d = d;
      best = q;
    }
  }
  return best;
}

Eigen::Matrix<double, 6, 6> jacobianFlange(const Joints& q) {
  const std::vector<Pose> links = linkPoses(q);
  const Eigen::Vector3d p_end = links[6].translation();
  Eigen::Matrix<double, 6, 6> J;
  // Joint axes: J1 z, J2 y, J3 y, J4 z, J5 y, J6 z, each in its own (child) link frame.
  const int axis[6] = {2, 1, 1, 2, 1, 2};
  for (int i = 0; i < 6; ++i) {
    const Eigen::Vector3d z = links[i + 1].linear().col(axis[i]);
    const Eigen::Vector3d p = links[i + 1].translation();
    J.block<3, 1>(0, i) = z.cross(p_end - p);
    J.block<3, 1>(3, i) = z;
  }
  return J;
}

std::vector<LinkCapsule> linkCapsules() {
  // Fitted to enclose every vertex of the public URDF meshes (test_kinematics checks this when
  // the meshes are available), radii rounded up by about 2 mm.
  return {
      {0, "base", {-0.019, 0, 0.060}, {-0.019, 0, 0.123}, 0.160},
      {1, "J1.turret", {0.036, 0, 0.285}, {0.036, 0, 0.340}, 0.167},
      {2, "J2.upper_arm", {0.002, 0.111, -0.006}, {0.002, 0.111, 0.357}, 0.096},
      {3, "J3.elbow", {-0.035, 0, 0.007}, {-0.035, 0, 0.158}, 0.133},
      {4, "J4.forearm", {0.004, 0.006, 0.959}, {0.004, 0.006, 1.092}, 0.092},
      {5, "J5.wrist", {0, 0, -0.021}, {0, 0, 0.054}, 0.050},
      {6, "J6.flange", {0, 0, -0.008}, {0, 0, 0}, 0.022},
  };
}

}  // namespace depowder::robot
