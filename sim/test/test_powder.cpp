// The powder height field: vacuum volumes (layer per pass, stand-off, sink rate), the residue
// left on parts and cleared by the air blast, relaxation to the angle of repose (volume
// conserved, stable, never into a part).
#include <gtest/gtest.h>

#include <cmath>

#include "depowder/sim/powder.hpp"

using namespace depowder::sim;

namespace {

constexpr double kSize = 0.30, kCell = 0.003, kArea = kCell * kCell;

// Cells (100 x 100 over 30 x 30 cm, centres at -0.15 + (i + 0.5) 3 mm) within r of xy, counted here.
int cellsWithin(double x, double y, double r) {
  int n = 0;
  for (int j = 0; j < 100; ++j)
    for (int i = 0; i < 100; ++i) n += std::hypot(-0.15 + (i + 0.5) * kCell - x, -0.15 + (j + 0.5) * kCell - y) <= r;
  return n;
}

// `steps` steps of the vacuum held at tip.
double hold(PowderField& f, const Eigen::Vector3d& tip, const VacuumConfig& v, int steps, double dt = 1.0 / 120) {
  double removed = 0;
  for (int k = 0; k < steps; ++k) {
    f.beginStep();
    removed += f.vacuum(tip, v, dt);
  }
  return removed;
}

// Relaxes to rest; returns the sweeps it took.
int relaxFully(PowderField& f, double repose) {
  int total = 0;
  for (int k = 0; k < 1000; ++k) {
    const int s = f.relax(repose, 1000, 1e-7);
    total += s;
    if (s < 1000) break;
  }
  return total;
}

}  // namespace

TEST(Powder, GridTilesTheInterior) {
  PowderField f(0.40, 0.30, 0.003);
  EXPECT_EQ(f.nx(), 133);
  EXPECT_EQ(f.ny(), 100);
  EXPECT_NEAR(f.nx() * f.dx(), 0.40, 1e-12);
  EXPECT_NEAR(f.centre(0, 0).x(), -0.20 + 0.5 * f.dx(), 1e-12);
  f.fill(0.05);
  EXPECT_NEAR(f.volume(), 0.40 * 0.30 * 0.05, 1e-12);
}

TEST(Powder, VacuumRemovesDownToTheStandoffWithinOneLayer) {
  VacuumConfig v;  // radius 1.5 cm, stand-off 1 cm, layer 5 mm
  const int n = cellsWithin(0, 0, v.radius);
  EXPECT_NEAR(n * kArea, M_PI * v.radius * v.radius, 0.05 * M_PI * v.radius * v.radius);

  // Tip 7 mm above the surface: the suction reaches 3 mm into it.
  PowderField a(kSize, kSize, kCell);
  a.fill(0.10);
  EXPECT_NEAR(hold(a, {0, 0, 0.107}, v, 120), 0.003 * n * kArea, 1e-12);
  EXPECT_NEAR(a.volume(), kSize * kSize * 0.10 - 0.003 * n * kArea, 1e-12);

  // Tip low: one pass takes one layer, however long the nozzle stays.
  PowderField b(kSize, kSize, kCell);
  b.fill(0.10);
  EXPECT_NEAR(hold(b, {0, 0, 0.09}, v, 240), v.layer_depth * n * kArea, 1e-12);
  int i, j;
  ASSERT_TRUE(b.cellOf({0.001, 0.001}, i, j));
  EXPECT_NEAR(b.height(b.index(i, j)), 0.095, 1e-12);
  // Leave (the pass ends), come back: a second layer.
  hold(b, {0.1, 0.1, 0.5}, v, 1);
  EXPECT_NEAR(hold(b, {0, 0, 0.09}, v, 240), v.layer_depth * n * kArea, 1e-12);
  EXPECT_NEAR(b.height(b.index(i, j)), 0.090, 1e-12);

  // The surface falls at sink_rate: one 10 ms step takes 1 mm.
  PowderField c(kSize, kSize, kCell);
  c.fill(0.10);
  EXPECT_NEAR(hold(c, {0, 0, 0.09}, v, 1, 0.01), v.sink_rate * 0.01 * n * kArea, 1e-12);
}

TEST(Powder, VacuumLeavesAResidueOnAPartAndTheAirBlastClearsIt) {
  PowderField f(kSize, kSize, kCell);
  // A part whose top is at 6 cm over a 4 x 4 cm square in the middle.
  std::vector<double> floor(f.size(), 0.0);
  std::vector<std::uint8_t> over(f.size(), 0);
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i)
      if (f.centre(i, j).cwiseAbs().maxCoeff() < 0.02) {
        floor[f.index(i, j)] = 0.06;
        over[f.index(i, j)] = 1;
      }
  f.setFloor(floor, over);
  f.fill(0.08);
  VacuumConfig v;
  for (int pass = 0; pass < 6; ++pass) {  // six passes of 5 mm would reach 5 cm; the part stops them
    hold(f, {0, 0, 0.05}, v, 120);
    hold(f, {0.1, 0.1, 0.5}, v, 1);
  }
  int i, j;
  ASSERT_TRUE(f.cellOf({0.001, 0.001}, i, j));
  EXPECT_NEAR(f.height(f.index(i, j)), 0.06 + v.residue, 1e-12);
  for (std::size_t c = 0; c < f.size(); ++c) ASSERT_GE(f.height(c), f.floor(c));

  AirConfig air;  // radius 3 cm: covers the part and a ring around it
  const double before = f.volume();
  double blown = 0;
  for (int k = 0; k < 240; ++k) {
    f.beginStep();
    blown += f.airBlast({0, 0, 0.12}, air, 1.0 / 120);
  }
  EXPECT_NEAR(before - f.volume(), blown, 1e-12);
  for (int jj = 0; jj < f.ny(); ++jj)
    for (int ii = 0; ii < f.nx(); ++ii) {
      const std::size_t c = f.index(ii, jj);
      if (f.centre(ii, jj).norm() > air.radius) continue;
      if (f.overPart(c))
        EXPECT_EQ(f.height(c), 0.06);  // bare
      else
        EXPECT_GE(f.height(c), 0.06 + v.residue - 1e-12 - air.extra_depth);  // at most one pass of extra_depth
    }
  // Out of reach (tip 20 cm above the surface): nothing happens.
  f.beginStep();
  EXPECT_EQ(f.airBlast({0.1, 0.1, 0.3}, air, 1.0), 0.0);
}

TEST(Powder, RelaxationConservesVolumeAndReachesTheAngleOfRepose) {
  PowderField f(kSize, kSize, kCell);
  f.fill(0.02);
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i)
      if (f.centre(i, j).norm() < 0.02) f.setHeight(f.index(i, j), 0.15);  // a 13 cm pillar
  const double v0 = f.volume();
  const double repose = 32;
  EXPECT_GT(f.maxSlopeExcess(repose), 0.1);
  const int sweeps = relaxFully(f, repose);
  EXPECT_GT(sweeps, 10);
  EXPECT_NEAR(f.volume(), v0, 1e-12);
  EXPECT_LE(f.maxSlopeExcess(repose), 1e-7);
  // The pillar became a cone whose flank stands at the angle of repose: along +x, between
  // radii where the flank is (above the 2 cm base), the slope is tan(32 deg).
  int i0, i1, j;
  ASSERT_TRUE(f.cellOf({0.0015 + 0.012, 0.0015}, i0, j));
  ASSERT_TRUE(f.cellOf({0.0015 + 0.030, 0.0015}, i1, j));
  const double h0 = f.height(f.index(i0, j)), h1 = f.height(f.index(i1, j));
  ASSERT_GT(h1, 0.02 + 0.001) << "the test points must lie on the flank";
  EXPECT_NEAR((h0 - h1) / ((i1 - i0) * kCell), std::tan(repose * M_PI / 180), 0.03);
}

TEST(Powder, AStablePileStaysExactlyAsItIs) {
  PowderField f(kSize, kSize, kCell);
  f.fill(0.0);
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i)  // a cone at 30 deg, under the 32 deg angle of repose
      f.setHeight(f.index(i, j), std::max(0.02, 0.10 - f.centre(i, j).norm() * std::tan(30 * M_PI / 180)));
  const std::vector<double> before = f.heights();
  EXPECT_EQ(f.relax(32, 100, 1e-7), 0);
  EXPECT_EQ(f.heights(), before);
  EXPECT_EQ(f.maxSlopeExcess(32), 0.0);
}

TEST(Powder, PowderOnAPartSlidesOffButNeverIntoIt) {
  PowderField f(kSize, kSize, kCell);
  std::vector<double> floor(f.size(), 0.0);
  std::vector<std::uint8_t> over(f.size(), 0);
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i)
      if (f.centre(i, j).cwiseAbs().maxCoeff() < 0.03) {
        floor[f.index(i, j)] = 0.06;
        over[f.index(i, j)] = 1;
      }
  f.setFloor(floor, over);
  f.fill(0.07);  // 1 cm of powder over the part
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i)
      if (!f.overPart(f.index(i, j))) f.setHeight(f.index(i, j), 0.01);  // dug all around it
  const double v0 = f.volume();
  relaxFully(f, 32);
  EXPECT_NEAR(f.volume(), v0, 1e-12);
  EXPECT_LE(f.maxSlopeExcess(32), 1e-7);
  int i, j;
  ASSERT_TRUE(f.cellOf({0.0015, 0.0015}, i, j));
  EXPECT_NEAR(f.height(f.index(i, j)), 0.07, 1e-9);  // the middle of the top keeps its layer
  ASSERT_TRUE(f.cellOf({0.0295, 0.0015}, i, j));
  EXPECT_LT(f.height(f.index(i, j)), 0.0605);  // the edge of the top is all but bare
  ASSERT_TRUE(f.cellOf({0.0315, 0.0015}, i, j));
  EXPECT_GT(f.height(f.index(i, j)), 0.011);  // and that powder lies beside the part
  for (std::size_t c = 0; c < f.size(); ++c) ASSERT_GE(f.height(c), f.floor(c));
}
