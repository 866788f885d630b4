// Physics (issue 4): rigid bodies from meshes (mass properties, convex pieces), the powder's support
// and drag, toppling, pushing to the wall, actuator and turntable speeds, powder displacement, and
// bit-identical seeded runs. Ground truth is analytic (a cube's mass and inertia, a commanded speed)
// or a physical outcome with a stated margin (fell to the dug side, reached the wall).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "depowder/parts.hpp"
#include "depowder/sim/physics.hpp"
#include "depowder/sim/push.hpp"
#include "depowder/sim/rigid_shape.hpp"
#include "depowder/sim/world.hpp"
#include "setup.hpp"

using namespace depowder;
using namespace depowder::sim;

namespace {

constexpr double kDt = 1.0 / 120;

Pose at(double x, double y, double z, double yaw_deg = 0) {
  return Eigen::Translation3d(x, y, z) * Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()) *
         Pose::Identity();
}

SimConfig physicsConfig() {
  SimConfig c;
  c.scene.table_size = 0;
  c.physics.enabled = true;
  return c;
}

// A straight tube along z, closed at both ends by rings: outer radius R, inner r, height H, centred.
Mesh tube(double R, double r, double H, int n = 24) {
  Mesh m;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    for (double rad : {R, r})
      for (double z : {-H / 2, H / 2}) m.vertices.emplace_back(rad * std::cos(a), rad * std::sin(a), z);
  }
  for (int k = 0; k < n; ++k) {  // 4k: outer bottom, +1 outer top, +2 inner bottom, +3 inner top
    const int a = 4 * k, b = 4 * ((k + 1) % n);
    m.triangles.emplace_back(a, b, b + 1);  // outer wall, facing out
    m.triangles.emplace_back(a, b + 1, a + 1);
    m.triangles.emplace_back(a + 2, a + 3, b + 3);  // inner wall, facing the axis
    m.triangles.emplace_back(a + 2, b + 3, b + 2);
    m.triangles.emplace_back(a + 1, b + 1, b + 3);  // top ring, up
    m.triangles.emplace_back(a + 1, b + 3, a + 3);
    m.triangles.emplace_back(a, a + 2, b + 2);  // bottom ring, down
    m.triangles.emplace_back(a, b + 2, b);
  }
  return m;
}

Eigen::Vector3d up(const Pose& T) { return T.linear() * Eigen::Vector3d::UnitZ(); }
double yawDeg(const Pose& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)) * 180 / M_PI; }

// Lowers the powder on the +y side of y0 at `rate` (m/s), to the box floor: the vacuum working one side.
void digPlusY(World& world, double y0, double rate) {
  PowderField& f = world.powder();
  for (int j = 0; j < f.ny(); ++j)
    for (int i = 0; i < f.nx(); ++i)
      if (f.centre(i, j).y() > y0) {
        const std::size_t c = f.index(i, j);
        f.setHeight(c, std::max(0.0, f.height(c) - rate * kDt));
      }
}

struct Fall {
  double first_tilt_time = -1;  ///< s when the tilt first passed 5 deg
  double rest_time = -1;        ///< s from which the part stayed still (speed < 1 mm/s, turn < 0.01 rad/s)
  Pose T_end;
};

// Steps for `seconds` with the +y side being dug until the part has tilted 45 deg (the vacuum then
// leaves, as a robot would).
Fall digAndWatch(World& world, double y0, double seconds) {
  Fall out;
  const Pose T0 = world.part(0).T_cell_part;
  bool digging = true;
  for (int k = 1; k * kDt <= seconds; ++k) {
    digging = digging && rotationAngle(world.part(0).T_cell_part.linear(), T0.linear()) < M_PI / 4;
    if (digging) digPlusY(world, y0, 0.1);
    world.step(kDt);
    const PartTruth t = world.partTruth(0);
    if (out.first_tilt_time < 0 && rotationAngle(t.T_cell_part.linear(), T0.linear()) > 5 * M_PI / 180)
      out.first_tilt_time = world.time();
    const bool still = t.speed < 0.001 && t.angular_speed < 0.01;
    if (!still) out.rest_time = -1;
    if (still && out.rest_time < 0) out.rest_time = world.time();
  }
  out.T_end = world.part(0).T_cell_part;
  return out;
}

}  // namespace

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

TEST(Physics, BuriedPartsDoNotMoveUnderGravity) {
  for (const std::string& name : parts::names()) {
    const Mesh mesh = parts::byName(name);
    // 1 cm of powder under the part, covered 1 cm over its top (the paper's initial state).
    const Pose T0 = at(0.01, -0.02, 0.01 - bounds(mesh).min().z(), 30);
    World world(physicsConfig(), BoxGeometry{}, {{name, mesh, T0, 1000}}, {});
    for (int k = 0; k < 1200; ++k) world.step(kDt);  // 10 s
    const Pose T = world.part(0).T_cell_part;
    EXPECT_LT(translationDistance(T, T0), 0.001) << name;
    EXPECT_LT(rotationAngle(T.linear(), T0.linear()), 0.5 * M_PI / 180) << name;
  }
}

TEST(Physics, TallPipeToppleTowardTheSideItsPowderWasRemovedFrom) {
  // A straight pipe 3 cm wide and 12 cm tall standing on 3 cm of powder, buried; the powder on its
  // +y side is taken away at 10 cm/s down to the floor. Control: the same pipe left alone stands.
  const Mesh pipe = tube(0.015, 0.011, 0.12);
  const Pose T0 = at(0, 0, 0.09);  // on 3 cm of powder
  World world(physicsConfig(), BoxGeometry{}, {{"pipe", pipe, T0, 1000}}, {});
  const Fall fall = digAndWatch(world, 0.0185, 10.0);
  const Eigen::Vector3d u = up(fall.T_end);
  EXPECT_GT(std::acos(std::clamp(u.z(), -1.0, 1.0)) * 180 / M_PI, 60);  // fell
  EXPECT_GT(u.y(), 0.5);                                                // to +y
  EXPECT_GT(u.y(), std::abs(u.x()));
  EXPECT_GT(fall.first_tilt_time, 0);
  EXPECT_GT(fall.rest_time, 0);                           // and lies still
  EXPECT_LT(fall.rest_time - fall.first_tilt_time, 3.0);  // falling takes a few seconds at most
  std::printf("straight pipe: tilted past 5 deg at %.2f s, at rest from %.2f s, up (%.2f %.2f %.2f)\n",
              fall.first_tilt_time, fall.rest_time, u.x(), u.y(), u.z());

  World control(physicsConfig(), BoxGeometry{}, {{"pipe", pipe, T0, 1000}}, {});
  for (int k = 0; k < 1200; ++k) control.step(kDt);
  EXPECT_LT(rotationAngle(control.part(0).T_cell_part.linear(), T0.linear()), 0.5 * M_PI / 180);
}

TEST(Physics, CellPipePerchedOnPowderFallsToTheDugSide) {
  // The default cell's pipe (an elbow) standing on 3 cm of powder, its +y side dug away.
  const Pose T0 = at(0, 0, 0.08);
  World world(physicsConfig(), BoxGeometry{}, {{"pipe", parts::pipe(), T0, 1000}}, {});
  const Fall fall = digAndWatch(world, 0.0185, 8.0);
  const Eigen::Vector3d u = up(fall.T_end);
  EXPECT_GT(u.y(), 0.7);
  EXPECT_LT(u.z(), 0.5);
  EXPECT_GT(fall.T_end.translation().y(), 0.02);
  EXPECT_GT(fall.rest_time, 0);
  EXPECT_LT(fall.rest_time - fall.first_tilt_time, 3.0);
  std::printf("cell pipe: tilted past 5 deg at %.2f s, at rest from %.2f s, up (%.2f %.2f %.2f)\n",
              fall.first_tilt_time, fall.rest_time, u.x(), u.y(), u.z());
}

// --- pushing to the wall (Table II) ---

struct PushCase {
  const char* name;
  Eigen::Vector2d start;  ///< cube centre, m
  double azimuth_deg, offset;
  bool steer;     ///< PushSpec::steer (sliding sideways along the face turns the part too: no sign then)
  int turn_sign;  ///< expected sign of the turn (0: not checked)
};

class PushToWall : public ::testing::TestWithParam<PushCase> {};

TEST_P(PushToWall, CubeMovesTurnsAndStopsAtTheWall) {
  const PushCase& c = GetParam();
  SimConfig config = physicsConfig();
  config.powder.level = 0.03;  // half the cube's height: visibility 0.5
  const Pose T0 = at(c.start.x(), c.start.y(), 0.03);
  World world(config, BoxGeometry{}, {{"cube", parts::cube(), T0, 1000}}, {});
  const double powder0 = world.powderInBox();
  PushSpec spec = pushFrom(world, 0, c.azimuth_deg, 0.5, c.offset);
  spec.speed = 0.03;
  spec.steer = c.steer;
  PushScript push(world, spec);
  bool touched = false;
  double turn = 0;  // deg, summed step by step (a cube's yaw repeats every 90 deg)
  for (int k = 1; k <= 30 * 120 && push.phase() != PushPhase::kDone; ++k) {
    const ArmState a = push.update(k * kDt);
    world.setNozzle(a.T_cell_nozzle, a.tool);
    const double yaw0 = yawDeg(world.part(0).T_cell_part);
    world.step(kDt);
    double d = yawDeg(world.part(0).T_cell_part) - yaw0;
    turn += d - 360 * std::round(d / 360);
    touched = touched || world.partTruth(0).nozzle_contact;
  }
  ASSERT_EQ(push.phase(), PushPhase::kDone) << c.name;
  EXPECT_EQ(push.outcome(), PushOutcome::kReachedWall) << c.name;
  EXPECT_TRUE(touched) << c.name;  // SIM_TRUTH's contact, with the nozzle a kinematic body
  EXPECT_GE(world.truth().contact_count, 1);
  // At the wall it was pushed toward (within the stop gap and a millimetre), and at rest there.
  const Pose T = world.part(0).T_cell_part;
  Eigen::AlignedBox3d b;
  for (const auto& v : world.part(0).mesh.vertices) b.extend(T * v);
  const Eigen::Vector2d dir(-std::cos(c.azimuth_deg * M_PI / 180), -std::sin(c.azimuth_deg * M_PI / 180));
  const Eigen::Vector3d half = 0.5 * world.box().size;
  double gap = 1e9;
  for (int a = 0; a < 2; ++a) {
    if (dir[a] > 0.3) gap = std::min(gap, half[a] - b.max()[a]);
    if (dir[a] < -0.3) gap = std::min(gap, b.min()[a] + half[a]);
  }
  EXPECT_LT(gap, spec.wall_gap + 0.001) << c.name;
  EXPECT_GT(gap, -0.001) << c.name;  // not into the wall
  EXPECT_GT(translationDistance(T, T0), 0.05) << c.name;
  EXPECT_LT(world.partTruth(0).speed, 0.001) << c.name;
  if (c.turn_sign != 0) {
    EXPECT_GT(c.turn_sign * turn, 10.0) << c.name << ": turned " << turn << " deg";
  }
  EXPECT_LT(std::abs(T.translation().z() - T0.translation().z()), 0.003) << c.name;  // slid, did not jump
  // The powder it pushed went somewhere: the powder in the box is kept (gaps under the part refilled).
  EXPECT_NEAR(world.powderInBox(), powder0, powder0 * 0.005) << c.name;
}

INSTANTIATE_TEST_SUITE_P(
    ContactPoints, PushToWall,
    ::testing::Values(PushCase{"centre_from_minus_x", {0.08, 0.0}, 180, 0.0, true, 0},
                      // Left of centre (seen along the push): the part turns clockwise; right: counter-clockwise.
                      PushCase{"left_of_centre", {0.08, 0.0}, 180, 0.01, false, -1},
                      PushCase{"right_of_centre", {0.08, 0.0}, 180, -0.01, false, +1},
                      PushCase{"from_plus_y_steered", {0.0, -0.04}, 90, 0.015, true, 0},
                      PushCase{"diagonal", {-0.1, -0.05}, 45, 0.0, true, 0}),
    [](const ::testing::TestParamInfo<PushCase>& param) { return std::string(param.param.name); });

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
