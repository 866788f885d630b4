// Physics (issue 4), the engine's parts: rigid bodies from meshes (mass properties, convex pieces),
// the powder's support and drag, actuator and turntable speeds, the powder a moving part pushes, and
// bit-identical seeded runs. Ground truth is analytic (a cube's mass and inertia, a commanded speed,
// the powder's volume). test_sim_dynamics has the whole-world outcomes (toppling, pushing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "depowder/parts.hpp"
#include "depowder/sim/physics.hpp"
#include "depowder/sim/push.hpp"
#include "depowder/sim/rigid_shape.hpp"
#include "depowder/sim/world.hpp"
#include "physics_helpers.hpp"
#include "setup.hpp"

using namespace depowder;
using namespace depowder::sim;
using namespace depowder::sim::test;

// --- rigid bodies from meshes ---

TEST(RigidShape, CubeMassAndInertiaAreAnalytic) {
  const Mesh cube = parts::cube();  // 6 cm
  const MassProperties m = massProperties(PartSolid(cube, 0.001), 1000, 0.0015);
  EXPECT_NEAR(m.volume, 216e-6, 216e-6 * 0.005);
  EXPECT_NEAR(m.mass, 0.216, 0.216 * 0.005);
  EXPECT_LT(m.centre.norm(), 1e-4);
  const double I = 0.216 * 0.06 * 0.06 / 6;  // m a^2 / 6 about any axis through the centre
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(m.inertia(a, a), I, I * 0.02);
  EXPECT_LT(std::abs(m.inertia(0, 1)) + std::abs(m.inertia(0, 2)) + std::abs(m.inertia(1, 2)), I * 0.01);
}

TEST(RigidShape, VolumeMatchesTheClosedMeshes) {
  for (const char* name : {"pipe", "cup", "cube"}) {
    const Mesh mesh = parts::byName(name);
    const MassProperties m = massProperties(PartSolid(mesh, 0.001), 1000, 0.0015);
    EXPECT_NEAR(m.volume, volume(mesh), volume(mesh) * 0.03) << name;
  }
}

TEST(RigidShape, CubeIsOneHullThePipeSeveralThatKeepItsElbowOpen) {
  const Mesh cube = parts::cube();
  const PartSolid cube_solid(cube, 0.001);
  const auto cube_pieces = convexDecomposition(cube, FilledSolid(cube, cube_solid), DecompositionConfig{});
  ASSERT_EQ(cube_pieces.size(), 1u);
  EXPECT_NEAR(cube_pieces[0].hull_volume, 216e-6, 216e-6 * 0.01);

  const Mesh pipe = parts::pipe();
  const PartSolid solid(pipe, 0.001);
  const FilledSolid filled(pipe, solid);
  const auto pieces = convexDecomposition(pipe, filled, DecompositionConfig{});
  ASSERT_GE(pieces.size(), 2u);
  double hull = 0, fill = 0;
  for (const auto& p : pieces) {
    hull += p.hull_volume;
    fill += p.filled_volume;
  }
  EXPECT_LT(hull, 1.25 * fill);
  EXPECT_GT(hullVolume(pipe.vertices), 1.4 * fill);  // one hull of the whole L would fill its elbow
  // Every vertex of the mesh is inside (or on) some piece; the inside of the elbow's corner is in none.
  auto inside = [&](const ConvexPiece& piece, const Eigen::Vector3d& q, double tolerance) {
    std::vector<Eigen::Vector3d> pts = piece.points;
    pts.push_back(q);
    return hullVolume(pts) <= piece.hull_volume + tolerance;
  };
  int outside = 0;
  for (std::size_t i = 0; i < pipe.vertices.size(); i += 3) {
    const Eigen::Vector3d& v = pipe.vertices[i];
    bool any = false;
    for (const auto& p : pieces) any = any || inside(p, v, 1e-9);
    outside += !any;
  }
  EXPECT_EQ(outside, 0);
  // The corner: above the horizontal leg (z from -5 to -2 cm), right of the vertical leg (x from -3.5 to -0.5 cm).
  const Eigen::Vector3d corner(0.02, 0.0, 0.01);
  ASSERT_FALSE(filled.contains(corner));
  for (const auto& p : pieces) EXPECT_FALSE(inside(p, corner, 1e-9));
}

// --- the powder's support and drag ---

TEST(PowderSupport, HoldsABuriedCubeAndItsDragGrowsWithDepthAndSpeed) {
  const Mesh cube = parts::cube();
  const PartSolid solid(cube, 0.001);
  const FilledSolid filled(cube, solid);
  const MassProperties m = massProperties(solid, 1000, 0.0015);
  const Eigen::Vector3d inertia = m.inertia.diagonal();
  PowderForceConfig config;
  PowderSupport support(config, outerSurfaceSamples(cube, filled, 0.006), Pose::Identity(), m.mass, inertia, 9.81);
  const double h = 0.001;
  const Eigen::Vector3d g_dv(0, 0, -9.81 * h);
  // The cube's centre at 5 cm: bottom at 2 cm. Buried under a 1 cm cover: held still against gravity.
  const Pose T = at(0, 0, 0.05);
  std::fill(support.levels().begin(), support.levels().end(), 0.09);
  for (int k = 0; k < 5; ++k) {
    const auto r = support.solve(T, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), g_dv, h);
    EXPECT_LT((r.v + g_dv).norm(), 1e-9) << "substep " << k;  // the velocity after gravity too
    EXPECT_LT(r.w.norm(), 1e-7);
  }
  // No powder: no force at all.
  std::fill(support.levels().begin(), support.levels().end(), -1.0);
  support.reset();
  const Eigen::Vector3d v(0.05, 0, 0);
  const auto free = support.solve(T, v, Eigen::Vector3d::Zero(), g_dv, h);
  EXPECT_EQ(free.buried, 0);
  EXPECT_LT((free.v - v).norm(), 1e-15);
  // Moving sideways through powder (no gravity, a short substep, so the powder slows the part without
  // stopping it): the speed lost grows with the depth (about as its square: pressure and area both
  // grow) and with the speed (the resistance doubles at drag_speed).
  auto slowdown = [&](double level, double speed) {
    std::fill(support.levels().begin(), support.levels().end(), level);
    support.reset();
    const Eigen::Vector3d v0(speed, 0, 0);
    const auto r = support.solve(T, v0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1e-4);
    return speed - r.v.x();
  };
  const double shallow = slowdown(0.035, 0.5), deep = slowdown(0.075, 0.5), faster = slowdown(0.075, 1.0);
  EXPECT_GT(shallow, 0);
  EXPECT_GT(deep, 3 * shallow);
  EXPECT_GT(faster, 1.5 * deep);
  EXPECT_LT(faster, 0.5);  // slowed, not stopped
}

// --- scripted motions (Fig. 10) ---

class ScriptedMotion : public ::testing::TestWithParam<bool> {};  // physics on / off

TEST_P(ScriptedMotion, ActuatorKeepsItsSpeedAndTheVisibility) {
  SimConfig config = physicsConfig();
  config.physics.enabled = GetParam();
  World world(config, BoxGeometry{}, {{"cube", parts::cube(), at(-0.05, 0, 0.03), 1000}}, {});
  world.digToVisibility(0, 0.6);
  Motion m;
  m.kind = Motion::Kind::kLinear;
  m.velocity = Eigen::Vector3d(0.03, 0.01, 0);
  m.start = 0.5;
  m.duration = 3.0;
  m.visibility = 0.6;
  world.setPartMotion(0, m);
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> times;
  for (int k = 1; k <= 5 * 120; ++k) {
    world.step(kDt);
    const PartTruth t = world.partTruth(0);
    if (world.time() > m.start + 0.05 && world.time() < m.start + m.duration - 0.05) {
      EXPECT_NEAR(t.speed, m.velocity.norm(), 0.02 * m.velocity.norm()) << "t " << world.time();
      EXPECT_NEAR(t.eta, 0.6, 0.03) << "t " << world.time();
      positions.push_back(t.T_cell_part.translation());
      times.push_back(world.time());
    }
  }
  // Mean velocity over the motion, from the true poses.
  const Eigen::Vector3d mean = (positions.back() - positions.front()) / (times.back() - times.front());
  EXPECT_NEAR(mean.x(), 0.03, 0.03 * 0.02);
  EXPECT_NEAR(mean.y(), 0.01, 0.01 * 0.02);
  EXPECT_NEAR(mean.z(), 0.0, 1e-9);
  // Released at the end: it stays where the actuator left it.
  EXPECT_FALSE(world.hasPartMotion(0));
  EXPECT_LT(world.partTruth(0).speed, 1e-3);
  EXPECT_NEAR(world.part(0).T_cell_part.translation().x(), -0.05 + 0.03 * 3.0, 0.001);
}

// A motion the world cannot run (a NaN or infinite figure, a negative duration) or a part it does
// not have is refused with the part named, and the part stays as it was.
TEST(ScriptedMotionInput, ABadMotionOrPartIsRefused) {
  World world(physicsConfig(), BoxGeometry{}, {{"cube", parts::cube(), at(-0.05, 0, 0.03), 1000}}, {});
  const auto refused = [&](const Motion& m, std::size_t part, const std::string& says) {
    try {
      world.setPartMotion(part, m);
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
      return true;
    }
    return false;
  };
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  Motion m;
  m.velocity.y() = nan;
  EXPECT_TRUE(refused(m, 0, "part 'cube': the velocity"));
  m = Motion{};
  m.kind = Motion::Kind::kTurntable;
  m.rate = inf;
  EXPECT_TRUE(refused(m, 0, "rate"));
  m.rate = 0.5;
  m.centre = Eigen::Vector2d(0, nan);
  EXPECT_TRUE(refused(m, 0, "centre"));
  m = Motion{};
  m.duration = -1;
  EXPECT_TRUE(refused(m, 0, "duration"));
  m.duration = nan;
  EXPECT_TRUE(refused(m, 0, "duration"));
  m = Motion{};
  m.start = nan;
  EXPECT_TRUE(refused(m, 0, "start"));
  EXPECT_TRUE(refused(Motion{}, 1, "no part 1"));
  EXPECT_FALSE(world.hasPartMotion(0));
  EXPECT_THROW(world.part(1), std::out_of_range);
  // A good one still runs, for ever by default.
  EXPECT_FALSE(refused(Motion{}, 0, ""));
  EXPECT_TRUE(world.hasPartMotion(0));
}

TEST_P(ScriptedMotion, TurntableKeepsItsRateAboutThePartsCentre) {
  SimConfig config = physicsConfig();
  config.physics.enabled = GetParam();
  const Mesh prop = parts::propeller();
  World world(config, BoxGeometry{}, {{"propeller", prop, at(0.02, 0.01, 0.01), 1000}}, {});
  world.digToVisibility(0, 0.6);
  Motion m;
  m.kind = Motion::Kind::kTurntable;
  m.rate = -40 * M_PI / 180;  // clockwise
  m.start = 0.25;
  m.duration = 4.0;
  m.visibility = 0.6;
  world.setPartMotion(0, m);
  double turned = 0;
  for (int k = 1; k <= 5 * 120; ++k) {
    const double yaw0 = yawDeg(world.part(0).T_cell_part);
    world.step(kDt);
    const PartTruth t = world.partTruth(0);
    double d = yawDeg(t.T_cell_part) - yaw0;
    d -= 360 * std::round(d / 360);
    turned += d;
    if (world.time() > m.start + 0.02 && world.time() < m.start + m.duration - 0.02) {
      EXPECT_NEAR(t.angular_speed, std::abs(m.rate), 0.02 * std::abs(m.rate)) << "t " << world.time();
      EXPECT_NEAR(d / kDt, m.rate * 180 / M_PI, 0.02 * std::abs(m.rate) * 180 / M_PI);
      EXPECT_LT(t.speed, 1e-6);  // the origin is the bounding-box centre: on the axis
    }
  }
  EXPECT_NEAR(turned, m.rate * m.duration * 180 / M_PI, 0.02 * std::abs(m.rate * m.duration) * 180 / M_PI);
  EXPECT_NEAR(world.partTruth(0).eta, 0.6, 0.03);
}

INSTANTIATE_TEST_SUITE_P(PhysicsOnOff, ScriptedMotion, ::testing::Bool());

TEST(Scenarios, ActuatorAndTurntableFilesGiveTheirSpeeds) {
  for (const auto& [file, speed, rate] : std::vector<std::tuple<std::string, double, double>>{
           {"actuator.yaml", 0.02, 0.0}, {"turntable.yaml", 0.0, 30 * M_PI / 180}}) {
    const SimSetup setup = loadSimSetup(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml",
                                        std::string(DEPOWDER_SOURCE_DIR) + "/config/scenarios/" + file);
    ASSERT_EQ(setup.motions.size(), 1u) << file;
    const Motion& m = setup.motions[0].motion;
    auto world = makeWorld(setup);
    for (int k = 1; k * kDt <= m.start + 2.0; ++k) world->step(kDt);
    const PartTruth t = world->partTruth(0);  // mid-motion
    EXPECT_NEAR(t.speed, speed, 0.02 * std::max(speed, 1e-3)) << file;
    EXPECT_NEAR(t.angular_speed, rate, 0.02 * std::max(rate, 1e-3)) << file;
    EXPECT_NEAR(t.eta, m.visibility, 0.03) << file;
  }
}

// --- the powder a moving part pushes ---

TEST(Displacement, PowderPilesUpInFrontFillsBehindAndIsKept) {
  SimConfig config;
  config.scene.table_size = 0;
  config.powder.relax_sweeps = 0;  // the displacement alone
  config.powder.level = 0.03;
  World world(config, BoxGeometry{}, {{"cube", parts::cube(), at(0, 0, 0.03), 1000}}, {});
  const double before = world.powderInBox();
  const PowderField& f = world.powder();
  auto heightAt = [&](double x, double y) {
    int i, j;
    f.cellOf({x, y}, i, j);
    return f.height(f.index(i, j));
  };
  // 1.2 cm along +x in 0.2 mm moves, turning 6 deg on the way.
  for (int k = 1; k <= 60; ++k) world.movePart(0, at(0.0002 * k, 0, 0.03, 0.1 * k));
  EXPECT_NEAR(world.powderInBox(), before, before * 1e-9);
  // In front (just past the moved cube's +x face), the powder went onto the cube: above its top.
  EXPECT_GT(heightAt(0.040, 0.0), 0.06 + 0.02);
  // Behind (where the cube was), the surface fell to the floor: the cube's own column left nothing.
  EXPECT_LT(heightAt(-0.027, 0.0), 0.005);
  // Far away, untouched.
  EXPECT_NEAR(heightAt(0.15, 0.1), 0.03, 1e-12);
}

// --- reproducibility ---

TEST(Physics, SeededRunsAreBitIdentical) {
  auto run = [] {
    SimConfig config = physicsConfig();
    config.powder.level = 0.03;
    World world(config, BoxGeometry{}, {{"cube", parts::cube(), at(0.05, 0.0, 0.03, 20), 1000}}, {}, 7);
    PushSpec spec = pushFrom(world, 0, 170, 0.5, 0.01);
    spec.speed = 0.04;
    PushScript push(world, spec);
    std::vector<Pose> poses;
    for (int k = 1; k <= 4 * 120; ++k) {
      const ArmState a = push.update(k * kDt);
      world.setNozzle(a.T_cell_nozzle, a.tool);
      world.step(kDt);
      poses.push_back(world.part(0).T_cell_part);
    }
    return std::make_pair(poses, world.powder().heights());
  };
  const auto a = run(), b = run();
  ASSERT_EQ(a.first.size(), b.first.size());
  for (std::size_t k = 0; k < a.first.size(); ++k)
    ASSERT_TRUE(a.first[k].matrix() == b.first[k].matrix()) << "step " << k;
  EXPECT_TRUE(a.second == b.second);
  EXPECT_GT(translationDistance(a.first.back(), a.first.front()), 0.02);  // it did move
}
