// VS-6577 forward / inverse kinematics against hand-computed poses of the joint chain
// (REFERENCE.md), IK round trips and the collision capsules against the public meshes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "depowder/mesh.hpp"
#include "depowder/robot/kinematics.hpp"

using namespace depowder;
using namespace depowder::robot;

namespace {

constexpr double kPi = 3.14159265358979323846;

void expectPose(const Pose& T, const Eigen::Vector3d& t, const Eigen::Matrix3d& R, double tol = 1e-12) {
  EXPECT_NEAR((T.translation() - t).norm(), 0.0, tol) << T.translation().transpose() << " vs " << t.transpose();
  EXPECT_NEAR(rotationAngle(T.linear(), R), 0.0, 1e-7);  // acos resolution ~2e-8
}

Eigen::Matrix3d ry(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix(); }
Eigen::Matrix3d rz(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

Joints randomJoints(const ArmConfig& arm, std::mt19937& rng) {
  Joints q;
  for (int i = 0; i < 6; ++i) q[i] = std::uniform_real_distribution<double>(arm.q_min[i], arm.q_max[i])(rng);
  return q;
}

ArmConfig cellArm() {
  ArmConfig arm;
  arm.T_cell_base = makePoseRpy({-0.55, 0.0, -0.10}, 0, 0, 0.1);
  arm.T_flange_nozzle = makePoseRpy({0.0, 0.0, 0.129}, 0, 0, 0);
  return arm;
}

}  // namespace

// Hand-computed from the chain: J2 at (0.075, 0, 0.335), J3 +0.365 z, J3->J5 (-0.090, 0, 0.405),
// flange +0.080 z.
TEST(Forward, ZeroPoseIsVertical) {
  expectPose(forwardFlange({0, 0, 0, 0, 0, 0}), {-0.015, 0, 1.185}, Eigen::Matrix3d::Identity());
}

TEST(Forward, HandComputedPoses) {
  // J2 = 90 deg: the whole arm lies along +x; J5 at (0.44 + 0.405, 0, 0.335 + 0.090).
  expectPose(forwardFlange({0, kPi / 2, 0, 0, 0, 0}), {0.925, 0, 0.425}, ry(kPi / 2));
  // J3 = 90 deg: forearm along +x from J3 at (0.075, 0, 0.700).
  expectPose(forwardFlange({0, 0, kPi / 2, 0, 0, 0}), {0.560, 0, 0.790}, ry(kPi / 2));
  // J1 = 90 deg: the zero pose turned about z.
  expectPose(forwardFlange({kPi / 2, 0, 0, 0, 0, 0}), {0, -0.015, 1.185}, rz(kPi / 2));
  // J5 = 90 deg: flange 80 mm sideways from the wrist centre (-0.015, 0, 1.105).
  expectPose(forwardFlange({0, 0, 0, 0, kPi / 2, 0}), {0.065, 0, 1.105}, ry(kPi / 2));
  // J4 = 90 deg then J5 = 90 deg: the flange swings towards +y.
  expectPose(forwardFlange({0, 0, 0, kPi / 2, kPi / 2, 0}), {-0.015, 0.080, 1.105}, rz(kPi / 2) * ry(kPi / 2));
  // J6 only turns the flange.
  expectPose(forwardFlange({0, 0, 0, 0, 0, 1.0}), {-0.015, 0, 1.185}, rz(1.0));
}

TEST(Forward, NozzleUsesBaseAndTool) {
  const ArmConfig arm = cellArm();
  const Joints q{0.3, 0.4, 1.2, -0.2, 1.1, 0.5};
  const Pose expected = arm.T_cell_base * forwardFlange(q) * arm.T_flange_nozzle;
  expectPose(forwardNozzle(arm, q), expected.translation(), expected.linear());
  const std::vector<Pose> links = linkPoses(q);
  ASSERT_EQ(links.size(), 7u);
  EXPECT_TRUE(links[0].isApprox(Pose::Identity()));
  EXPECT_TRUE(links[6].isApprox(forwardFlange(q), 1e-15));
  // Link frames of the URDF: J4's origin lies 0.700 below J3 along J3's z.
  EXPECT_NEAR((links[4].translation() - links[3] * Eigen::Vector3d(-0.090, 0, -0.700)).norm(), 0, 1e-12);
}

TEST(Limits, WithinLimits) {
  ArmConfig arm;
  EXPECT_TRUE(withinLimits(arm, {0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(withinLimits(arm, {3.0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(withinLimits(arm, {0, -1.8, 0, 0, 0, 0}));
  EXPECT_FALSE(withinLimits(arm, {0, 0, 0, 0, 0, NAN}));
}

// IK round trip over seeded random joint configurations (so the pose is reachable within limits),
// from an unrelated seed: FK(IK(pose)) must reproduce the pose within 1e-6 m / 1e-6 rad.
TEST(Inverse, RoundTripsRandomPoses) {
  const ArmConfig arm = cellArm();
  std::mt19937 rng(42);
  int solved = 0;
  const int n = 5000;
  for (int k = 0; k < n; ++k) {
    const Joints q = randomJoints(arm, rng);
    const Joints seed = randomJoints(arm, rng);
    const Pose target = forwardNozzle(arm, q);
    const auto sol = inverseNozzle(arm, target, seed);
    ASSERT_TRUE(sol.has_value()) << "k=" << k;
    ASSERT_TRUE(withinLimits(arm, *sol));
    const Pose got = forwardNozzle(arm, *sol);
    ASSERT_LT(translationDistance(got, target), 1e-6) << "k=" << k;
    ASSERT_LT(rotationAngle(got.linear(), target.linear()), 1e-6) << "k=" << k;
    // The chosen solution is never farther from the seed than the generating one.
    ASSERT_LE(jointDistance(arm, *sol, seed), jointDistance(arm, q, seed) + 1e-9) << "k=" << k;
    ++solved;
  }
  EXPECT_EQ(solved, n);
}

TEST(Inverse, SeedAtSolutionReturnsIt) {
  const ArmConfig arm = cellArm();
  std::mt19937 rng(7);
  for (int k = 0; k < 2000; ++k) {
    const Joints q = randomJoints(arm, rng);
    const auto sol = inverseNozzle(arm, forwardNozzle(arm, q), q);
    ASSERT_TRUE(sol.has_value());
    for (int i = 0; i < 6; ++i) {
      // Near the wrist singularity only q4 + q6 is observable; compare it there.
      if (std::abs(std::sin(q[4])) < 1e-6 && (i == 3 || i == 5)) continue;
      ASSERT_NEAR((*sol)[i], q[i], 1e-6) << "k=" << k << " joint " << i;
    }
  }
}

TEST(Inverse, EightBranchesForAGenericPose) {
  ArmConfig arm;
  // Wide limits so that every branch is admissible.
  arm.q_min.fill(-10);
  arm.q_max.fill(10);
  // Wrist centre at (0.05, 0, 0.5), close to the J1 axis: front and back shoulder both reach it.
  Pose T = makePoseRpy({0, 0, 0}, 0.4, 0.9, -0.3);
  T.translation() = Eigen::Vector3d(0.05, 0, 0.5) + 0.080 * T.linear().col(2);
  const Joints q{0, 0, 0, 0, 0, 0};
  const auto all = inverseFlangeAll(arm, T, q);
  ASSERT_EQ(all.size(), 8u);
  for (const Joints& s : all) {
    EXPECT_LT(translationDistance(forwardFlange(s), T), 1e-9);
    EXPECT_LT(rotationAngle(forwardFlange(s).linear(), T.linear()), 1e-7);  // acos resolution
  }
}

TEST(Inverse, SingularitiesAndUnreachable) {
  const ArmConfig arm;
  // Zero pose: J5 = 0 (wrist singular), wrist centre 15 mm off the J1 axis.
  const Joints zero{0, 0, 0, 0, 0, 0};
  const auto s0 = inverseNozzle(arm, forwardNozzle(arm, zero), zero);
  ASSERT_TRUE(s0.has_value());
  for (int i = 0; i < 6; ++i) EXPECT_NEAR((*s0)[i], 0.0, 1e-9);
  // Wrist singular with a seed that has q4 = 0.5: q4 + q6 is preserved and q4 stays at the seed.
  const Joints seed{0, 0, 0, 0.5, 0.01, 0};
  const auto s1 = inverseNozzle(arm, forwardNozzle(arm, {0, 0.2, 0.3, 0, 0, 0.8}), seed);
  ASSERT_TRUE(s1.has_value());
  EXPECT_NEAR((*s1)[3], 0.5, 1e-9);
  EXPECT_NEAR((*s1)[3] + (*s1)[5], 0.8, 1e-9);
  // Beyond reach (wrist centre 2 m away), and an invalid pose.
  EXPECT_FALSE(inverseNozzle(arm, makePoseRpy({2.0, 0, 0.4}, 0, 0, 0), zero).has_value());
  Pose bad = Pose::Identity();
  bad.linear() *= 2.0;
  EXPECT_FALSE(inverseNozzle(arm, bad, zero).has_value());
  // Reachable only with J1 beyond its +-170 deg limit: the point straight behind the base.
  ArmConfig narrow;
  narrow.q_min[0] = -0.5;
  narrow.q_max[0] = 0.5;
  narrow.q_min[1] = -0.1;  // forbid leaning backwards
  const Pose behind = makePoseRpy({-0.6, 0.0, 0.3}, kPi, 0, 0);
  EXPECT_FALSE(inverseNozzle(narrow, behind, zero).has_value());
}

TEST(Jacobian, MatchesFiniteDifferences) {
  const Joints q{0.3, 0.4, 1.2, -0.2, 1.1, 0.5};
  const auto J = jacobianFlange(q);
  const double h = 1e-7;
  for (int i = 0; i < 6; ++i) {
    Joints qp = q, qm = q;
    qp[i] += h;
    qm[i] -= h;
    const Pose Tp = forwardFlange(qp), Tm = forwardFlange(qm);
    const Eigen::Vector3d v = (Tp.translation() - Tm.translation()) / (2 * h);
    const Eigen::AngleAxisd aa(Tp.linear() * Tm.linear().transpose());
    const Eigen::Vector3d w = aa.angle() * aa.axis() / (2 * h);
    EXPECT_NEAR((J.block<3, 1>(0, i) - v).norm(), 0, 1e-6) << "joint " << i;
    EXPECT_NEAR((J.block<3, 1>(3, i) - w).norm(), 0, 1e-6) << "joint " << i;
  }
}

// The capsules must enclose the public URDF meshes (every vertex, 1 mm tolerance).
TEST(Capsules, EncloseUrdfMeshes) {
  const std::filesystem::path dir = std::filesystem::path(DEPOWDER_SHARED_DATA) / "robot" / "vs6577_meshes";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no reference meshes at " << dir;
  const auto caps = linkCapsules();
  const char* names[7] = {"base_link", "J1", "J2", "J3", "J4", "J5", "J6"};
  for (int link = 0; link < 7; ++link) {
    const Mesh mesh = loadMesh((dir / (std::string(names[link]) + ".stl")).string());
    double worst = 0;
    for (const auto& v : mesh.vertices) {
      double best = 1e9;
      for (const auto& c : caps) {
        if (c.link != link) continue;
        const Eigen::Vector3d d = c.p1 - c.p0;
        const double t = d.squaredNorm() > 0 ? std::clamp((v - c.p0).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
        best = std::min(best, (v - (c.p0 + t * d)).norm() - c.radius);
      }
      worst = std::max(worst, best);
    }
    EXPECT_LT(worst, 1e-3) << names[link] << " sticks out of its capsules by " << worst << " m";
  }
}

// The end effector's cylinders (the cell's robot.effector) hold the authors' vacuum end effector,
// mm, its axis along z from the flange face (measured: 44.48 mm from the axis at most up to
// 7.0 mm along it, 28.6 mm from there to 128.9 mm), and fit it: the single cylinder of its
// widest radius the cell had before was 16 mm too wide along 94 % of its length.
TEST(Capsules, EffectorCylindersHoldTheAuthorsEndEffector) {
  const std::filesystem::path path = std::filesystem::path(DEPOWDER_SHARED_DATA) / "robot" / "vacuum_end_effector.stl";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no reference mesh at " << path;
  ArmConfig arm = cellArm();
  arm.T_flange_nozzle.translation() = Eigen::Vector3d(0, 0, 0.25);  // config/cell.yaml: the end effector and a tube
  const std::vector<EffectorBody> bodies = effectorBodies(arm.effector, arm.T_flange_nozzle);
  ASSERT_EQ(bodies.size(), 2u);
  std::vector<double> room(bodies.size(), 1.0);  // per cylinder: how far inside it its points stay at the least, m
  for (const Eigen::Vector3d& v : loadMesh(path.string(), 0.001).vertices) {
    bool inside = false;
    for (std::size_t k = 0; k < bodies.size(); ++k) {
      const Eigen::Vector3d local = bodies[k].T_flange_body.inverse() * v;
      if (std::abs(local.z()) > 0.5 * bodies[k].length + 1e-9) continue;
      inside = inside || local.head<2>().norm() <= bodies[k].radius;
      room[k] = std::min(room[k], bodies[k].radius - local.head<2>().norm());
    }
    EXPECT_TRUE(inside) << "vertex (" << v.transpose() << ") is outside the end effector's cylinders";
  }
  EXPECT_LT(room[0], 0.0005);  // each cylinder as wide as the mesh, within 0.5 mm
  EXPECT_LT(room[1], 0.0005);
  // One after the other from the flange (the placing itself: test_geometry).
  EXPECT_TRUE(bodies[0].T_flange_end().translation().isApprox(Eigen::Vector3d(0, 0, 0.008)));
  EXPECT_TRUE(bodies[1].T_flange_end().translation().isApprox(Eigen::Vector3d(0, 0, 0.129)));
}
