// The World: true eta by Eq. 2 on analytic cases, the band, digging to a set visibility (all five
// parts, stable under relaxation), exposure of a part's side, nozzle occlusion and contact,
// moving parts, and bit-identical seeded runs.
#include <gtest/gtest.h>

#include <cmath>

#include "analytic.hpp"
#include "depowder/parts.hpp"
#include "depowder/sim/script.hpp"
#include "depowder/sim/world.hpp"

using namespace depowder;
using namespace depowder::sim;
using namespace depowder::sim::test;

namespace {

Pose at(double x, double y, double z) { return Pose(Eigen::Translation3d(x, y, z)); }

// A part resting on the floor at (x, y) (its frame origin is its bounding-box centre).
PartSpec resting(const std::string& name, double x = 0, double y = 0) {
  Mesh m = parts::byName(name);
  return {name, m, at(x, y, -bounds(m).min().z()), 1000};
}

SimConfig quietConfig() {
  SimConfig c;
  c.scene.table_size = 0;
  return c;
}

CameraModel sideCamera(int w = 320, int h = 240) {
  return CameraModel::fromFov("SIDE", w, h, 70, 55, lookAt({0.0, -0.30, 0.50}, {0, 0, 0.03}));
}

// Distance from xy to the square [-a, a]^2.
double squareDistance(const Eigen::Vector2d& p, double a) {
  const Eigen::Vector2d d = (p.cwiseAbs() - Eigen::Vector2d::Constant(a)).cwiseMax(0.0);
  return d.norm();
}

}  // namespace

TEST(WorldEta, FlatPowderGivesEq2) {
  SimConfig config = quietConfig();
  World world(config, BoxGeometry{}, {resting("cube")}, {});
  const PartTruth t0 = world.partTruth(0);
  EXPECT_NEAR(t0.h_max, 0.06, 1e-12);
  EXPECT_NEAR(t0.h_min, 0.0, 1e-12);
  EXPECT_EQ(t0.eta, 0.0);  // buried at the start: cover above the top
  for (double level : {0.0, 0.015, 0.03, 0.045, 0.06, 0.08}) {
    world.setPowderLevel(level);
    const PartTruth t = world.partTruth(0);
    EXPECT_NEAR(t.h_pow, level, 1e-12);
    EXPECT_NEAR(t.eta, (0.06 - std::min(level, 0.06)) / 0.06, 1e-12) << "level " << level;
  }
}

TEST(WorldEta, SlopedPowderAveragesOverTheSymmetricBand) {
  // h = a + b x + c y: over a band symmetric about the part the mean is a.
  World world(quietConfig(), BoxGeometry{}, {resting("cube")}, {});
  PowderField& f = world.powder();
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i) {
      const Eigen::Vector2d p = f.centre(i, j);
      f.setHeight(f.index(i, j), 0.025 + 0.1 * p.x() - 0.05 * p.y());
    }
  EXPECT_NEAR(world.partTruth(0).eta, (0.06 - 0.025) / 0.06, 1e-9);
}

TEST(WorldEta, BandIsTheRingOneToOneAndAHalfCentimetresOut) {
  World world(quietConfig(), BoxGeometry{}, {resting("cube")}, {});
  PowderField& f = world.powder();
  // Mark the band by height: cells at analytic distance [1.0, 1.5) cm from the 6 cm square at 1 cm,
  // everything else at 3 cm. Cells within half a cell of the band's edges may go either way.
  const double half_diag = 0.5 * std::hypot(f.dx(), f.dy());
  int sure = 0, unsure = 0;
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i) {
      const double d = squareDistance(f.centre(i, j), 0.03);
      const bool in = d >= 0.010 && d < 0.015;
      f.setHeight(f.index(i, j), in ? 0.01 : 0.03);
      if (in && d > 0.010 + half_diag && d < 0.015 - half_diag) ++sure;
      if (std::abs(d - 0.010) <= half_diag || std::abs(d - 0.015) <= half_diag) ++unsure;
    }
  const PartTruth t = world.partTruth(0);
  // Ring area: (s + 2 r)^2 - corners... = 4 s (r1 - r0) + pi (r1^2 - r0^2) for a square of side s.
  const double ring = 4 * 0.06 * 0.005 + M_PI * (0.015 * 0.015 - 0.010 * 0.010);
  EXPECT_NEAR(t.band_cells * f.cellArea(), ring, 0.15 * ring);
  // Mean height: at most the unsure cells can be wrong.
  const double wrong_fraction = std::abs(t.h_pow - 0.01) / 0.02;
  EXPECT_LE(wrong_fraction * t.band_cells, unsure);
  EXPECT_GE(t.band_cells, sure);
}

TEST(WorldEta, TiltedPartUsesThePosedMeshHeights) {
  // A 6 cm cube rolled by 30 deg and yawed: its height span is 6 (cos 30 + sin 30) cm.
  PartSpec cube{"cube", parts::cube(), makePoseRpy({0.05, -0.02, 0.06}, 30 * M_PI / 180, 0, 0.4), 1000};
  World world(quietConfig(), BoxGeometry{}, {cube}, {});
  const PartTruth t = world.partTruth(0);
  const double span = 0.06 * (std::cos(M_PI / 6) + std::sin(M_PI / 6));
  EXPECT_NEAR(t.h_max - t.h_min, span, 1e-9);
  EXPECT_NEAR(t.h_max, 0.06 + span / 2, 1e-9);
  world.setPowderLevel(0.05);
  EXPECT_NEAR(world.partTruth(0).eta, (t.h_max - 0.05) / span, 1e-9);
}

class DigToVisibility : public ::testing::TestWithParam<std::string> {};

TEST_P(DigToVisibility, TrueEtaIsTheTargetAndTheCraterIsStable) {
  for (double eta : {0.2, 0.4, 0.6, 0.8, 1.0}) {
    World world(quietConfig(), BoxGeometry{}, {resting(GetParam(), 0.02, -0.01)}, {});
    world.digToVisibility(0, eta);
    EXPECT_NEAR(world.partTruth(0).eta, eta, 1e-9) << GetParam() << " at " << eta;
    const double volume = world.powder().volume();
    for (int k = 0; k < 60; ++k) world.step(1.0 / 120);  // no tool: only relaxation could change it
    EXPECT_NEAR(world.partTruth(0).eta, eta, 1e-9);
    EXPECT_NEAR(world.powder().volume(), volume, 1e-12);
    EXPECT_LE(world.powder().maxSlopeExcess(world.config().powder.repose_deg), 1e-6);
  }
}

INSTANTIATE_TEST_SUITE_P(AllParts, DigToVisibility, ::testing::ValuesIn(parts::names()));

TEST(World, DiggingBesideAPartExposesItsSide) {
  auto sidePixels = [](const DepthImage& img, double z_lo, double z_hi) {
    int n = 0;
    for (const Point& p : img.cellCloud())  // on a side face of the cube [-3, 3] cm x [-3, 3] cm x [0, 6] cm
      if (p.z() > z_lo && p.z() < z_hi && p.head<2>().cwiseAbs().maxCoeff() < 0.031 &&
          std::abs(p.head<2>().cwiseAbs().maxCoeff() - 0.03) < 0.001)
        ++n;
    return n;
  };
  World world(quietConfig(), BoxGeometry{}, {resting("cube")}, {sideCamera()});
  EXPECT_EQ(sidePixels(world.render(0, nullptr), 0.0, 0.06), 0);  // buried
  world.digToVisibility(0, 0.5);                                  // powder at 3 cm around it
  const DepthImage img = world.render(0, nullptr);
  EXPECT_GT(sidePixels(img, 0.032, 0.058), 80);  // the upper half of the side shows (130 px here)
  EXPECT_EQ(sidePixels(img, 0.0, 0.028), 0);     // the lower half is still in the powder
}

TEST(World, NozzleOccludesAndTouches) {
  World world(quietConfig(), BoxGeometry{}, {resting("cube")}, {sideCamera()});
  world.setPowderLevel(0.0);
  const DepthImage without = world.render(0, nullptr);
  const Eigen::Vector3d down(0, 0, -1);
  world.setNozzle(nozzlePose({0, 0, 0.08}, down), Tool::kOff);
  world.step(0.01);
  const DepthImage with = world.render(0, nullptr);
  int nearer = 0, farther = 0;
  for (std::size_t i = 0; i < with.depth.size(); ++i) {
    if (with.depth[i] == without.depth[i]) continue;
    const bool closer = with.depth[i] != 0 && (without.depth[i] == 0 || with.depth[i] < without.depth[i]);
    (closer ? nearer : farther)++;
  }
  EXPECT_GT(nearer, 300);  // the nozzle hides the cube and the floor behind it
  EXPECT_EQ(farther, 0);
  EXPECT_FALSE(world.truth().parts[0].nozzle_contact);

  // Into the top of the cube: a contact; out and in again: a second one.
  world.setNozzle(nozzlePose({0, 0, 0.055}, down), Tool::kOff);
  world.step(0.01);
  EXPECT_TRUE(world.truth().parts[0].nozzle_contact);
  EXPECT_EQ(world.truth().contact_count, 1);
  world.setNozzle(nozzlePose({0, 0, 0.065}, down), Tool::kOff);
  world.step(0.01);
  EXPECT_FALSE(world.truth().parts[0].nozzle_contact);
  world.setNozzle(nozzlePose({0.04, 0, 0.02}, down), Tool::kOff);  // beside it, 2.5 mm into its side
  world.step(0.01);
  EXPECT_TRUE(world.truth().parts[0].nozzle_contact);
  EXPECT_EQ(world.truth().contact_count, 2);
  world.setNozzle(nozzlePose({0.045, 0, 0.02}, down), Tool::kOff);  // 2.5 mm clear of it
  world.step(0.01);
  EXPECT_FALSE(world.truth().parts[0].nozzle_contact);
}

// An ArmSource's state as one call: the nozzle set or taken out, the links moved when the state
// carries their poses and left where they are when it does not.
TEST(World, SetArmAppliesAnArmSourcesState) {
  World world(quietConfig(), BoxGeometry{}, {resting("cube")}, {sideCamera()});
  world.setPowderLevel(0.0);
  ArmState arm;
  arm.nozzle_present = true;
  arm.T_cell_nozzle = nozzlePose({0, 0, 0.055}, {0, 0, -1});  // into the cube's top
  arm.tool = Tool::kAir;
  world.setArm(arm);
  EXPECT_TRUE(world.nozzlePresent());
  EXPECT_EQ(world.tool(), Tool::kAir);
  EXPECT_TRUE(world.nozzlePose().isApprox(arm.T_cell_nozzle));
  world.step(0.01);
  EXPECT_TRUE(world.truth().parts[0].nozzle_contact);
  world.setArm(ArmState{});  // no nozzle in the cell
  EXPECT_FALSE(world.nozzlePresent());
  EXPECT_EQ(world.tool(), Tool::kOff);
  world.step(0.01);
  EXPECT_FALSE(world.truth().parts[0].nozzle_contact);

  // A 2 cm link cube: into the part, then a state without link poses leaves it there.
  world.setArmLinks({parts::box({0.02, 0.02, 0.02}, 4)});
  ArmState linked;
  linked.T_cell_links = {at(0, 0, 0.05)};
  world.setArm(linked);
  world.step(0.01);
  EXPECT_TRUE(world.truth().parts[0].nozzle_contact);
  world.setArm(ArmState{});
  world.step(0.01);
  EXPECT_TRUE(world.truth().parts[0].nozzle_contact);
  linked.T_cell_links = {at(0, 0, 0.05), at(0, 0, 0.2)};
  EXPECT_THROW(world.setArm(linked), std::invalid_argument);  // one link mesh, two poses
}

TEST(World, VacuumVolumeIsAccountedFor) {
  World world(quietConfig(), BoxGeometry{}, {resting("cube", 0.1, 0)}, {});
  const double v0 = world.powder().volume();
  // A vacuum pass along a line away from the part, with relaxation on.
  for (int k = 0; k <= 240; ++k) {
    world.setNozzle(nozzlePose({-0.15 + 0.001 * k, -0.05, 0.065}, {0, 0, -1}), Tool::kVacuum);
    world.step(1.0 / 120);
  }
  const Truth t = world.truth();
  EXPECT_GT(t.powder_removed_m3, 0.5 * 0.005 * 0.03 * 0.24);  // most of a 5 mm layer, 3 cm wide, 24 cm long
  EXPECT_NEAR(t.powder_volume_m3, v0 - t.powder_removed_m3, 1e-12);
  EXPECT_EQ(t.tool, Tool::kVacuum);
}

TEST(World, MovingAPartMovesItsFloorAndBand) {
  World world(quietConfig(), BoxGeometry{}, {resting("cube")}, {});
  world.setPowderLevel(0.03);
  int i, j;
  ASSERT_TRUE(world.powder().cellOf({0.001, 0.001}, i, j));
  const std::size_t centre = world.powder().index(i, j);
  EXPECT_NEAR(world.powder().floor(centre), 0.06, 1e-12);
  world.setPartPose(0, at(0.1, 0, 0.03));
  world.step(0.5);
  EXPECT_EQ(world.powder().floor(centre), 0.0);
  ASSERT_TRUE(world.powder().cellOf({0.101, 0.001}, i, j));
  EXPECT_NEAR(world.powder().floor(world.powder().index(i, j)), 0.06, 1e-12);
  const PartTruth t = world.partTruth(0);
  EXPECT_NEAR(t.T_cell_part.translation().x(), 0.1, 1e-12);
  EXPECT_NEAR(t.speed, 0.1 / 0.5, 1e-12);
  EXPECT_NEAR(t.eta, 0.5, 1e-9);
}

TEST(World, SeededRunsAreBitIdentical) {
  const std::vector<CameraModel> cams{
      sideCamera(), CameraModel::fromFov("TOP", 320, 240, 70, 55, lookAt({0.1, 0.4, 0.5}, {0, 0, 0}))};
  Orbit orbit;
  orbit.radii = {0.06, 0.05};
  orbit.height = 0.075;
  orbit.period = 2;
  orbit.tool = Tool::kVacuum;
  ScriptSegment seg;
  seg.kind = ScriptSegment::Kind::kOrbit;
  seg.orbit = orbit;
  const NozzleScript script({seg}, true);
  auto run = [&](std::uint32_t seed) {
    World world(SimConfig{}, BoxGeometry{}, {resting("cube"), resting("owl", -0.1, 0.05)}, cams, seed);
    std::vector<std::vector<std::uint16_t>> frames;
    std::vector<double> etas;
    for (int k = 1; k <= 240; ++k) {
      const ArmState s = script.at(k / 120.0);
      world.setNozzle(s.T_cell_nozzle, s.tool);
      world.step(1.0 / 120);
      if (k % 4 == 0)
        for (std::size_t c = 0; c < cams.size(); ++c) frames.push_back(world.render(c).depth);
      etas.push_back(world.partTruth(0).eta);
    }
    etas.push_back(world.truth().powder_removed_m3);
    return std::pair{frames, etas};
  };
  const auto a = run(11), b = run(11), c = run(12);
  ASSERT_EQ(a.first.size(), 120u);
  EXPECT_EQ(a.first, b.first);
  EXPECT_EQ(a.second, b.second);
  EXPECT_NE(a.first, c.first);    // another seed, other noise
  EXPECT_EQ(a.second, c.second);  // the same world
  EXPECT_GT(a.second.back(), 0);  // the vacuum did dig
}

// A part mesh with a hole or wound inward has no inside to push or weigh: refused, naming the part.
TEST(World, PartsWithoutAnInsideAreRefusedByName) {
  auto refusal = [](Mesh mesh) {
    try {
      World(quietConfig(), BoxGeometry{}, {{"open_cup", std::move(mesh), at(0, 0, 0.05), 1000}}, {});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  Mesh open = parts::byName("cube");
  open.triangles.pop_back();
  EXPECT_NE(refusal(open).find("World: part 'open_cup' is not a closed surface: the edge from ("), std::string::npos)
      << refusal(open);
  Mesh inward = parts::byName("cube");
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  EXPECT_NE(refusal(inward).find("World: part 'open_cup' is wound inward"), std::string::npos) << refusal(inward);
  EXPECT_EQ(refusal(parts::byName("cube")), "accepted");
}
