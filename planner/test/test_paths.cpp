// Vacuum loops and the air-blast raster against ground truth computed by brute force
// (depowder::distanceToMesh), independent of the FCL queries the planner uses.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "depowder/parts.hpp"
#include "depowder/planner/paths.hpp"
#include "fixtures.hpp"

using namespace depowder;
using namespace depowder::planner;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Shortest distance from the vertical nozzle axis (tip .. tip + length up) to the mesh,
/// by brute force at 1 mm steps along the axis.
double axisDistance(const Mesh& posed, const Point& tip, double length) {
  double best = 1e9;
  for (double z = 0; z <= length + 1e-9; z += 0.001) best = std::min(best, distanceToMesh(posed, tip + Point(0, 0, z)));
  return best;
}

using test::syntheticContour;

struct Case {
  std::string part;
  Pose T_cell_part;
};

std::vector<Case> cases() {
  return {{"cube", makePoseRpy({0.02, -0.01, 0.03}, 0, 0, 0.3)},
          {"cup", makePoseRpy({-0.05, 0.02, 0.04}, 0, 0, 1.0)},
          {"propeller", makePoseRpy({0.0, 0.0, 0.012}, 0, 0, 0.2)},
          {"owl", makePoseRpy({0.05, 0.03, 0.045}, 0, 0, -0.5)},
          {"pipe", makePoseRpy({0.0, 0.0, 0.06}, 0, 0, 0)},
          {"pipe-lying", makePoseRpy({0.03, -0.02, 0.016}, kPi / 2, 0, 0.4)}};
}

class LoopTest : public ::testing::TestWithParam<Case> {};

std::string baseName(const std::string& n) { return n.substr(0, n.find('-')); }

TEST_P(LoopTest, ContourLoopKeepsTheStandoff) {
  const Case c = GetParam();
  const PartShape part(c.part, parts::byName(baseName(c.part)));
  const Mesh posed = transformed(part.mesh(), c.T_cell_part);
  const HeightRange hr = partHeights(part, c.T_cell_part);
  const double powder = 0.5 * (hr.min + hr.max);
  PlannerConfig config;
  const Cloud contour = syntheticContour(posed, powder, 0.0125);
  const Point nozzle_now(0.3, 0.2, 0.3);
  const LoopResult loop = contourLoop(part, c.T_cell_part, contour, powder, nozzle_now, config);
  ASSERT_TRUE(loop.ok()) << loop.reason;
  EXPECT_EQ(loop.source, LoopSource::kContour);
  ASSERT_GE(loop.tips.size(), 10u);
  EXPECT_NEAR(loop.height, powder - config.vacuum.layer_depth, 1e-12);
  EXPECT_EQ((loop.tips.front() - loop.tips.back()).norm(), 0.0) << "closed loop";

  const double s = config.vacuum.standoff;
  double lo = 1e9;
  for (std::size_t i = 0; i + 1 < loop.tips.size(); ++i) {
    const Point& t = loop.tips[i];
    EXPECT_NEAR(t.z(), loop.height, 1e-12);
    const double d = axisDistance(posed, t, config.nozzle.length);
    lo = std::min(lo, d);
    EXPECT_GE(d, s - 0.002) << c.part << " waypoint " << i;
    // Spacing along the loop.
    EXPECT_LE((loop.tips[i + 1] - t).norm(), config.vacuum.spacing * 1.6) << c.part << " gap after " << i;
  }
  EXPECT_NEAR(lo, s, 0.002) << c.part;
  EXPECT_NEAR(loop.min_standoff, s, 0.001);
  // The first waypoint is the loop point nearest the nozzle.
  for (const Point& t : loop.tips) EXPECT_LE((loop.tips.front() - nozzle_now).norm(), (t - nozzle_now).norm() + 1e-12);
}

TEST_P(LoopTest, FootprintLoopKeepsTheStandoff) {
  const Case c = GetParam();
  const PartShape part(c.part, parts::byName(baseName(c.part)));
  const Mesh posed = transformed(part.mesh(), c.T_cell_part);
  const HeightRange hr = partHeights(part, c.T_cell_part);
  PlannerConfig config;
  const double powder = hr.min + 0.3 * (hr.max - hr.min);
  const LoopResult loop = footprintLoop(part, c.T_cell_part, powder, Point(-0.3, 0, 0.3), config);
  ASSERT_TRUE(loop.ok()) << loop.reason;
  EXPECT_EQ(loop.source, LoopSource::kFootprint);
  const double s = config.vacuum.standoff;
  double lo = 1e9;
  for (std::size_t i = 0; i + 1 < loop.tips.size(); ++i) {
    const double d = axisDistance(posed, loop.tips[i], config.nozzle.length);
    lo = std::min(lo, d);
    EXPECT_GE(d, s - 0.002) << c.part << " waypoint " << i;
  }
  EXPECT_NEAR(lo, s, 0.002) << c.part;
}

INSTANTIATE_TEST_SUITE_P(Parts, LoopTest, ::testing::ValuesIn(cases()), [](const auto& param_info) {
  std::string n = param_info.param.part;
  for (char& ch : n)
    if (ch == '-') ch = '_';
  return n;
});

/// Distance from p to the closed polyline `loop` in xy.
double distanceToLoop(const Cloud& loop, const Point& p) {
  double best = 1e9;
  for (std::size_t i = 0; i + 1 < loop.size(); ++i) {
    const Eigen::Vector2d a = loop[i].head<2>(), b = loop[i + 1].head<2>(), q = p.head<2>();
    const double t = std::clamp((q - a).dot(b - a) / std::max(1e-12, (b - a).squaredNorm()), 0.0, 1.0);
    best = std::min(best, (a + t * (b - a) - q).norm());
  }
  return best;
}

TEST(ContourLoop, MovedPartMovesThePath) {
  const PartShape part("cube", parts::byName("cube"));
  PlannerConfig config;
  const Pose T0 = makePoseRpy({0.0, 0.0, 0.03}, 0, 0, 0.2);
  const Pose T1 = makePoseRpy({0.025, -0.012, 0.03}, 0, 0, 0.2);
  const Point nozzle_now(0.06, 0.0, 0.05);
  const auto contour0 = syntheticContour(transformed(part.mesh(), T0), 0.04, 0.0125);
  const auto contour1 = syntheticContour(transformed(part.mesh(), T1), 0.04, 0.0125);
  const LoopResult a = contourLoop(part, T0, contour0, 0.04, nozzle_now, config);
  const LoopResult b = contourLoop(part, T1, contour1, 0.04, nozzle_now, config);
  ASSERT_TRUE(a.ok() && b.ok());
  const Point shift = T1.translation() - T0.translation();
  Cloud moved = a.tips;
  for (Point& p : moved) p += shift;
  // Every new waypoint lies on the old loop translated by the part's motion (within 1 mm).
  for (const Point& p : b.tips) EXPECT_LT(distanceToLoop(moved, p), 0.001);
  Point ca = Point::Zero(), cb = Point::Zero();
  for (std::size_t i = 0; i + 1 < a.tips.size(); ++i) ca += a.tips[i] / double(a.tips.size() - 1);
  for (std::size_t i = 0; i + 1 < b.tips.size(); ++i) cb += b.tips[i] / double(b.tips.size() - 1);
  EXPECT_NEAR((cb - ca - shift).norm(), 0.0, 0.002);
  // No jump: the new loop starts where the nozzle is nearest (within half a waypoint spacing of
  // the nearest point of the new loop's polyline).
  EXPECT_LT((b.tips.front() - nozzle_now).head<2>().norm(), distanceToLoop(b.tips, nozzle_now) + config.vacuum.spacing);
}

TEST(ContourLoop, RejectsBadInput) {
  const PartShape part("cube", parts::byName("cube"));
  PlannerConfig config;
  const Pose T = makePoseRpy({0, 0, 0.03}, 0, 0, 0);
  const Cloud contour = syntheticContour(transformed(part.mesh(), T), 0.04, 0.0125);
  const Point now(0.1, 0, 0.1);

  EXPECT_EQ(contourLoop(part, T, {}, 0.04, now, config).status, PathStatus::kEmptyContour);
  Cloud nan = contour;
  nan[5].x() = std::nan("");
  const LoopResult r = contourLoop(part, T, nan, 0.04, now, config);
  EXPECT_EQ(r.status, PathStatus::kInvalidContour);
  EXPECT_TRUE(r.tips.empty());
  EXPECT_NE(r.reason.find("non-finite"), std::string::npos) << r.reason;
  EXPECT_EQ(contourLoop(part, T, Cloud(contour.begin(), contour.begin() + 3), 0.04, now, config).status,
            PathStatus::kInvalidContour);
  Cloud away = contour;
  for (Point& p : away) p.x() += 0.2;
  const LoopResult r2 = contourLoop(part, T, away, 0.04, now, config);
  EXPECT_EQ(r2.status, PathStatus::kInvalidContour);
  EXPECT_NE(r2.reason.find("enclose"), std::string::npos) << r2.reason;
  EXPECT_EQ(contourLoop(part, T, contour, std::nan(""), now, config).status, PathStatus::kInvalidHeight);
  Pose bad = T;
  bad.translation().x() = std::nan("");
  EXPECT_EQ(contourLoop(part, bad, contour, 0.04, now, config).status, PathStatus::kInvalidPose);
  EXPECT_EQ(footprintLoop(part, bad, 0.04, now, config).status, PathStatus::kInvalidPose);
  EXPECT_EQ(blastRaster(part, bad, now, config).status, PathStatus::kInvalidPose);
}

TEST(LoopHeight, OneLayerBelowThePowderButNotBelowThePart) {
  const PartShape part("cube", parts::byName("cube"));
  VacuumConfig vc;
  const Pose T = makePoseRpy({0, 0, 0.05}, 0, 0, 0);  // cube spans z 0.02 .. 0.08
  EXPECT_NEAR(loopHeight(part, T, 0.06, vc), 0.06 - vc.layer_depth, 1e-12);
  EXPECT_NEAR(loopHeight(part, T, 0.021, vc), 0.02, 1e-9);
  EXPECT_NEAR(loopHeight(part, makePoseRpy({0, 0, 0.0}, 0, 0, 0), 0.0, vc), vc.min_tip_height, 1e-12);
}

TEST(LoopHeight, UndercutGoesBelowThePartDownToTheFloorClearance) {
  const PartShape part("cube", parts::byName("cube"));
  VacuumConfig vc;
  vc.undercut = 0.01;
  const Pose T = makePoseRpy({0, 0, 0.05}, 0, 0, 0);  // cube spans z 0.02 .. 0.08
  EXPECT_NEAR(loopFloor(part, T, vc), 0.01, 1e-9);
  EXPECT_NEAR(loopHeight(part, T, 0.021, vc), 0.016, 1e-9) << "one layer below the powder, under the bottom";
  EXPECT_NEAR(loopHeight(part, T, 0.012, vc), 0.01, 1e-9) << "no deeper than the undercut";
  vc.undercut = 0.05;
  EXPECT_NEAR(loopFloor(part, T, vc), vc.min_tip_height, 1e-12) << "never below the floor clearance";
}

TEST(BuriedPart, LoopRunsAroundThePartAtThePowderHeight) {
  // Phase 1: the powder is above the part's top; the loop still circles the part's footprint.
  const PartShape part("cube", parts::byName("cube"));
  PlannerConfig config;
  const Pose T = makePoseRpy({0, 0, 0.03}, 0, 0, 0);
  const LoopResult loop = footprintLoop(part, T, 0.12, Point(0.1, 0, 0.2), config);
  ASSERT_TRUE(loop.ok()) << loop.reason;
  EXPECT_NEAR(loop.height, 0.12 - config.vacuum.layer_depth, 1e-12);
  for (const Point& t : loop.tips) {
    // Horizontal distance to the 6 cm cube's side: at least the stand-off, at most stand-off + 2 mm.
    const double dx = std::max(0.0, std::abs(t.x()) - 0.03), dy = std::max(0.0, std::abs(t.y()) - 0.03);
    EXPECT_NEAR(std::hypot(dx, dy), config.vacuum.standoff, 0.002);
  }
}

TEST(BlastRaster, CoversThePartFromAboveAtTheStandoff) {
  PlannerConfig config;
  for (const std::string& name : parts::names()) {
    const PartShape part(name, parts::byName(name));
    const Pose T = makePoseRpy({0.01, -0.02, 0.06}, 0.2, 0, 0.7);
    const Mesh posed = transformed(part.mesh(), T);
    const RasterResult r = blastRaster(part, T, Point(0.3, 0.3, 0.3), config);
    ASSERT_TRUE(r.ok()) << r.reason;
    EXPECT_GE(r.lines, 3) << name;
    const HeightRange hr = partHeights(part, T);
    for (const Point& t : r.tips) {
      EXPECT_GE(distanceToMesh(posed, t), config.blast.standoff - 1e-3) << name;
      EXPECT_LE(t.z(), hr.max + config.blast.standoff + 1e-9) << name;
    }
    // Coverage: every surface sample lies within half a line spacing (plus the step) of the
    // raster in xy, so the air jet passes over all of the part.
    const auto samples = sampleSurface(posed, 0.01, 3).points;
    for (const Point& p : samples) {
      double best = 1e9;
      for (const Point& t : r.tips) best = std::min(best, (t - p).head<2>().norm());
      EXPECT_LE(best, 0.5 * std::hypot(config.blast.spacing, config.blast.step) + 1e-6) << name;
    }
    // Boustrophedon from the corner nearest the nozzle (+x +y).
    EXPECT_GT(r.tips.front().x(), T.translation().x());
    EXPECT_GT(r.tips.front().y(), T.translation().y());
  }
}

}  // namespace
