// Helpers shared by the physics tests.
#pragma once

#include <algorithm>
#include <cmath>

#include "depowder/sim/world.hpp"

namespace depowder::sim::test {

constexpr double kDt = 1.0 / 120;

inline Pose at(double x, double y, double z, double yaw_deg = 0) {
  return Eigen::Translation3d(x, y, z) * Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()) *
         Pose::Identity();
}

inline SimConfig physicsConfig() {
  SimConfig c;
  c.scene.table_size = 0;
  c.physics.enabled = true;
  return c;
}

// A straight tube along z, closed at both ends by rings: outer radius R, inner r, height H, centred.
inline Mesh tube(double R, double r, double H, int n = 24) {
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

inline Eigen::Vector3d up(const Pose& T) { return T.linear() * Eigen::Vector3d::UnitZ(); }
inline double yawDeg(const Pose& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)) * 180 / M_PI; }

// Lowers the powder on the +y side of y0 at `rate` (m/s), to the box floor: the vacuum working one side.
inline void digPlusY(World& world, double y0, double rate) {
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
inline Fall digAndWatch(World& world, double y0, double seconds) {
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

}  // namespace depowder::sim::test
