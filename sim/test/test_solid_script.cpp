// Point-in-part tests (contact) on single- and multi-shell parts, the top envelope, and the
// scripted nozzle (orbit and waypoints).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "depowder/parts.hpp"
#include "depowder/sim/script.hpp"
#include "depowder/sim/solid.hpp"

using namespace depowder;
using namespace depowder::sim;

TEST(PartSolid, CubeInsideAndOutside) {
  const PartSolid s(parts::cube());  // 6 cm, centred
  EXPECT_TRUE(s.contains({0, 0, 0}));
  EXPECT_TRUE(s.contains({0.029, -0.029, 0.029}));
  EXPECT_FALSE(s.contains({0.031, 0, 0}));
  EXPECT_FALSE(s.contains({0, 0, -0.031}));
  EXPECT_FALSE(s.contains({0.2, 0, 0}));
}

TEST(PartSolid, CupWallFloorAndCavity) {
  // The cup (parts.cpp): outer radius 3.2 cm, wall 3.5 mm, floor 5 mm, 7.5 cm tall, handle on +x,
  // centred on its bounding box: the axis is at x = -(3.2 + 1.75 + 0.45 - 3.2) / 2 cm... measured here.
  const Mesh cup = parts::cup();
  const Eigen::AlignedBox3d b = bounds(cup);
  const double axis_x = b.min().x() + 0.032, bottom = b.min().z();
  const PartSolid s(cup);
  EXPECT_FALSE(s.contains({axis_x, 0, 0}));         // the cavity
  EXPECT_TRUE(s.contains({axis_x + 0.030, 0, 0}));  // in the wall (2.85 .. 3.2 cm)
  EXPECT_TRUE(s.contains({axis_x - 0.030, 0, 0}));
  EXPECT_TRUE(s.contains({axis_x, 0.010, bottom + 0.0025}));  // in the floor
  EXPECT_FALSE(s.contains({axis_x - 0.034, 0, 0}));           // beside it
}

TEST(PartSolid, OverlappingShellsCountOnce) {
  // The propeller's blades are buried in its hub: inside either is inside; the bore is not.
  // The mesh is centred on its bounding box; the hub axis is 5.8 cm from the tip of the blade on +y
  // (parts.cpp), which is the vertex with the largest y.
  const Mesh prop = parts::propeller();
  Eigen::Vector3d tip = prop.vertices[0];
  for (const auto& v : prop.vertices)
    if (v.y() > tip.y()) tip = v;
  const Eigen::Vector3d axis = tip - Eigen::Vector3d(0, 0.058, 0);
  const PartSolid s(prop);
  EXPECT_TRUE(s.contains(axis + Eigen::Vector3d(0.006, 0.0, 0.0)));   // hub, where blade roots overlap it
  EXPECT_TRUE(s.contains(axis + Eigen::Vector3d(0.0, 0.010, 0.0)));   // hub and the +y blade's root
  EXPECT_FALSE(s.contains(axis + Eigen::Vector3d(0.0, 0.0, 0.0)));    // the shaft bore (0.3 cm)
  EXPECT_FALSE(s.contains(axis + Eigen::Vector3d(0.0, 0.0, 0.015)));  // above the hub
  // Mid-blade on +y: the cambered section at r = 3.5 cm (pitch 36.4 deg) lies 0.25 to 3 mm along
  // its thickness direction (sin p, 0, cos p) from the radius line.
  const double p = (55 - 35 * (0.035 - 0.009) / 0.049) * M_PI / 180;
  EXPECT_TRUE(
      s.contains(axis + Eigen::Vector3d(0.0, 0.035, 0.0) + 0.0016 * Eigen::Vector3d(std::sin(p), 0, std::cos(p))));
  EXPECT_FALSE(
      s.contains(axis + Eigen::Vector3d(0.0, 0.035, 0.0) - 0.002 * Eigen::Vector3d(std::sin(p), 0, std::cos(p))));
}

TEST(PartSolid, MonteCarloVolumeOfThePipe) {
  const Mesh pipe = parts::pipe();  // one closed shell: volume() is exact
  const PartSolid s(pipe);
  const Eigen::AlignedBox3d b = bounds(pipe);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(b.min().x(), b.max().x()), uy(b.min().y(), b.max().y()),
      uz(b.min().z(), b.max().z());
  const int n = 40000;
  int inside = 0;
  for (int k = 0; k < n; ++k) inside += s.contains({ux(rng), uy(rng), uz(rng)});
  const double p = double(inside) / n, estimate = p * b.volume();
  const double stderr_ = std::sqrt(p * (1 - p) / n) * b.volume();
  EXPECT_NEAR(estimate, volume(pipe), 4 * stderr_ + 0.01 * volume(pipe));
}

TEST(Envelope, TopAndBottomOfATiltedSquare) {
  // A unit square tilted 45 deg about y: z = x over x in [-0.5 cos, 0.5 cos].
  Mesh m;
  const double c = std::sqrt(0.5);
  m.vertices = {
      {-0.5 * c, -0.5, -0.5 * c}, {0.5 * c, -0.5, 0.5 * c}, {0.5 * c, 0.5, 0.5 * c}, {-0.5 * c, 0.5, -0.5 * c}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  ColumnGrid g;
  g.x0 = -0.5;
  g.y0 = -0.5;
  g.dx = g.dy = 0.1;
  g.nx = g.ny = 11;
  std::vector<double> top, bottom;
  meshEnvelope(m.vertices, m.triangles, g, top, bottom);
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const double x = g.x0 + i * g.dx;
      const std::size_t k = static_cast<std::size_t>(j) * g.nx + i;
      if (std::abs(x) < 0.5 * c - 1e-9) {
        EXPECT_NEAR(top[k], x, 1e-12);
        EXPECT_NEAR(bottom[k], x, 1e-12);
      } else if (std::abs(x) > 0.5 * c + 1e-9) {
        EXPECT_TRUE(std::isinf(top[k]));
      }
    }
}

TEST(Script, OrbitFollowsTheEllipseDescendsAndTilts) {
  Orbit o;
  o.centre = {0.01, -0.02};
  o.radii = {0.08, 0.05};
  o.height = 0.12;
  o.period = 8;
  o.descend_per_rev = 0.01;
  o.min_height = 0.095;
  o.revolutions = 4;
  o.tilt_deg = 20;
  o.tool = Tool::kVacuum;
  ScriptSegment seg;
  seg.kind = ScriptSegment::Kind::kOrbit;
  seg.orbit = o;
  const NozzleScript script({seg}, false);
  EXPECT_DOUBLE_EQ(script.duration(), 32);
  const ArmState quarter = script.at(2.0);  // a quarter turn: at +y of the centre, 2.5 mm lower
  ASSERT_TRUE(quarter.nozzle_present);
  EXPECT_TRUE(quarter.T_cell_nozzle.translation().isApprox(Eigen::Vector3d(0.01, 0.03, 0.1175), 1e-12));
  EXPECT_EQ(quarter.tool, Tool::kVacuum);
  // The spray axis leans 20 deg from straight down, toward the centre (-y here).
  const Eigen::Vector3d spray = quarter.T_cell_nozzle.linear().col(2);
  EXPECT_NEAR(std::acos(-spray.z()) * 180 / M_PI, 20, 1e-9);
  EXPECT_LT(spray.y(), 0);
  EXPECT_NEAR(spray.x(), 0, 1e-12);
  EXPECT_NEAR(script.at(30).T_cell_nozzle.translation().z(), 0.095, 1e-12);         // held at min_height
  EXPECT_TRUE(script.at(100).T_cell_nozzle.isApprox(script.at(32).T_cell_nozzle));  // not looping: holds the end
}

TEST(Script, WaypointsInterpolateAndLoop) {
  ScriptSegment seg;
  seg.waypoints = {{0.0, nozzlePose({0, 0, 0.2}, {0, 0, -1}), Tool::kOff},
                   {2.0, nozzlePose({0.1, 0, 0.1}, {0, 0, -1}), Tool::kVacuum},
                   {3.0, nozzlePose({0.1, 0.1, 0.1}, {1, 0, -1}), Tool::kAir}};
  const NozzleScript script({seg}, true);
  EXPECT_DOUBLE_EQ(script.duration(), 3);
  const ArmState mid = script.at(1.0);
  EXPECT_TRUE(mid.T_cell_nozzle.translation().isApprox(Eigen::Vector3d(0.05, 0, 0.15), 1e-12));
  EXPECT_EQ(mid.tool, Tool::kVacuum);  // the tool of the waypoint travelled to
  const ArmState turning = script.at(2.5);
  EXPECT_NEAR(std::acos(-turning.T_cell_nozzle.linear().col(2).z()) * 180 / M_PI, 22.5, 1e-6);  // half of 45 deg
  EXPECT_EQ(turning.tool, Tool::kAir);
  EXPECT_TRUE(script.at(4.0).T_cell_nozzle.isApprox(script.at(1.0).T_cell_nozzle, 1e-12));  // loops
  EXPECT_FALSE(NozzleScript().at(1.0).nozzle_present);
  EXPECT_THROW(NozzleScript({ScriptSegment{}}, false), std::invalid_argument);  // no waypoints
}
