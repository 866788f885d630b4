#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "depowder/geometry.hpp"
#include "depowder/point_grid.hpp"

using namespace depowder;

TEST(Geometry, RotationAngleOfKnownRotation) {
  const Pose a = makePoseRpy({0, 0, 0}, 0, 0, 0);
  const Pose b = makePoseRpy({0, 0, 0}, 0, 0, 0.5);
  EXPECT_NEAR(rotationAngle(a.linear(), b.linear()), 0.5, 1e-12);
  EXPECT_NEAR(rotationAngle(b.linear(), b.linear()), 0.0, 1e-7);
}

// A turn about z comes back whole, on either side of pi; a tip added to it changes it little.
TEST(Geometry, TurnAboutVerticalOfKnownRotations) {
  for (const double a : {0.0, 0.3, -1.2, 2.9, -3.0})
    EXPECT_NEAR(turnAboutVertical(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix()), a, 1e-12);
  const Eigen::Matrix3d tipped =
      (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  EXPECT_NEAR(turnAboutVertical(tipped), 0.5, 0.01);
}

TEST(Geometry, ValidPoseRejectsNanAndShear) {
  Pose p = makePoseRpy({1, 2, 3}, 0.1, 0.2, 0.3);
  EXPECT_TRUE(isValidPose(p));
  Pose nan = p;
  nan.translation().x() = std::nan("");
  EXPECT_FALSE(isValidPose(nan));
  Pose shear = p;
  shear.linear()(0, 1) += 0.1;
  EXPECT_FALSE(isValidPose(shear));
}

TEST(Geometry, OnNozzleBodyGrowsTheBodyByEachMargin) {
  // A body 25 cm long, 1.25 cm round, grown by 2 cm past its ends and 0.5 cm round its side.
  auto on = [](double x, double y, double z) { return onNozzleBody({x, y, z}, 0.25, 0.0125, 0.02, 0.005); };
  EXPECT_TRUE(on(0, 0, -0.1));
  EXPECT_TRUE(on(0.017, 0, -0.1));       // within 1.75 cm of the axis
  EXPECT_FALSE(on(0.013, 0.013, -0.1));  // 1.84 cm off it
  EXPECT_TRUE(on(0, 0, 0.019));          // just below the tip's margin (+z sprays away from the body)
  EXPECT_FALSE(on(0, 0, 0.021));
  EXPECT_TRUE(on(0, 0, -0.269));  // the far end's margin
  EXPECT_FALSE(on(0, 0, -0.271));
  EXPECT_FALSE(onNozzleBody({0, 0, -0.1}, 0.25, 0.0125, 0.02, -0.0125));  // no radius left: nothing
}

// The end effector's sections one after another from the flange on the line to the tip, cut at
// the tip, whichever way the tool offset points; a section of no radius leaves a gap, one beyond
// the tip is left out.
TEST(Geometry, EffectorBodiesFollowEachOtherToTheTipAndStopThere) {
  const Eigen::Vector3d axis(0, 0.6, 0.8);  // a tool offset 0.08 m along it, tilted 37 deg from the flange's z
  const Pose T_flange_nozzle = makePoseRpy(0.08 * axis, 0.3, -0.2, 1.0);  // the nozzle's turn plays no part
  const std::vector<EffectorBody> bodies =
      effectorBodies({{0.04, 0.01}, {0, 0.02}, {0.03, 0.1}, {0.05, 0.1}}, T_flange_nozzle);
  ASSERT_EQ(bodies.size(), 2u);
  const auto from = [](const EffectorBody& e) { return e.T_flange_end() * Eigen::Vector3d(0, 0, -e.length); };
  EXPECT_LT(from(bodies[0]).norm(), 1e-12);
  EXPECT_LT((bodies[0].T_flange_end().translation() - 0.01 * axis).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(bodies[0].radius, 0.04);
  EXPECT_LT((from(bodies[1]) - 0.03 * axis).norm(), 1e-12);
  EXPECT_LT((bodies[1].T_flange_end().translation() - T_flange_nozzle.translation()).norm(), 1e-12);  // cut
  EXPECT_NEAR(bodies[1].length, 0.05, 1e-12);
  EXPECT_DOUBLE_EQ(bodies[1].radius, 0.03);
  for (const EffectorBody& e : bodies) {
    EXPECT_TRUE(isValidPose(e.T_flange_body));
    EXPECT_LT((e.T_flange_body.linear().col(2) - axis).norm(), 1e-12);  // z towards the tip
    EXPECT_LT((e.T_flange_body.translation() - e.T_flange_end() * Eigen::Vector3d(0, 0, -0.5 * e.length)).norm(),
              1e-12);  // centred
  }
  EXPECT_TRUE(effectorBodies(vacuumEffector(), Pose::Identity()).empty());  // a tip on the flange
  double length = 0;
  for (const EffectorSection& s : vacuumEffector()) length += s.length;
  EXPECT_NEAR(length, 0.129, 1e-12);  // the authors' end effector
}

// A segment's frame: at its middle, z along it, a proper rotation; a point segment keeps no turn.
TEST(Geometry, SegmentFrameIsCentredWithZAlongTheSegment) {
  const Eigen::Vector3d p0(0.1, -0.2, 0.3), p1(0.4, 0.2, 0.3);
  const Pose T = segmentFrame(p0, p1);
  EXPECT_TRUE(isValidPose(T));
  EXPECT_LT((T.translation() - Eigen::Vector3d(0.25, 0.0, 0.3)).norm(), 1e-12);
  EXPECT_LT((T.linear().col(2) - Eigen::Vector3d(0.6, 0.8, 0.0)).norm(), 1e-12);
  EXPECT_LT((T * Eigen::Vector3d(0, 0, 0.25) - p1).norm(), 1e-12);  // half its length of 0.5 m up z
  EXPECT_TRUE(segmentFrame(p0, p0).linear().isIdentity());
}

TEST(PointGrid, NearestMatchesBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  Cloud cloud(5000);
  for (auto& p : cloud) p = Point(u(rng), u(rng), u(rng) * 0.5);
  const PointGrid grid(cloud, 0.01);
  for (int k = 0; k < 2000; ++k) {
    const Point q(u(rng), u(rng), u(rng));
    const double r = k % 2 ? 0.01 : 0.03;  // also radii larger than the cell
    int best = -1;
    double best_d2 = r * r;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if ((cloud[i] - q).squaredNorm() <= best_d2) {
        best_d2 = (cloud[i] - q).squaredNorm();
        best = static_cast<int>(i);
      }
    }
    const auto hit = grid.nearest(q, r);
    ASSERT_EQ(hit.index, best) << "query " << k;
    ASSERT_EQ(grid.anyWithin(q, r), best >= 0) << "query " << k;
    if (best >= 0) {
      EXPECT_DOUBLE_EQ(hit.distance2, best_d2);
    }
  }
}

TEST(PointGrid, EmptyCloudAndNanQueryFindNothing) {
  const Cloud empty;
  EXPECT_FALSE(PointGrid(empty, 0.01).nearest(Point::Zero(), 1.0).found());
  const Cloud one{Point::Zero()};
  EXPECT_FALSE(PointGrid(one, 0.01).nearest(Point(NAN, 0, 0), 1.0).found());
  EXPECT_FALSE(PointGrid(empty, 0.01).anyWithin(Point::Zero(), 1.0));
  EXPECT_FALSE(PointGrid(one, 0.01).anyWithin(Point(NAN, 0, 0), 1.0));
}

TEST(VoxelDownsample, OneCentroidPerVoxel) {
  Cloud cloud;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) cloud.emplace_back(0.001 * i, 0.001 * j, 0.0);  // 1 cm square, 1 mm pitch
  cloud.emplace_back(NAN, 0, 0);
  const Cloud down = voxelDownsample(cloud, 0.005);
  ASSERT_EQ(down.size(), 4u);
  for (const auto& p : down) EXPECT_TRUE(p.allFinite());
  EXPECT_NEAR(down[0].x(), 0.002, 1e-12);  // mean of 0..4 mm
}
