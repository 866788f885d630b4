#include "emulated_arm.hpp"

#include <cmath>

namespace depowder::sim {

Mesh capsuleMesh(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double radius, int segments) {
  // A UV sphere split at its equator, the halves moved to p0 and p1: closed, outward.
  Eigen::Vector3d axis = p1 - p0;
  const double length = axis.norm();
  axis = length > 1e-9 ? Eigen::Vector3d(axis / length) : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  const int rings = segments / 2;  // per hemisphere
  Mesh m;
  for (int r = 0; r <= 2 * rings + 1; ++r) {  // latitude rings from the p0 pole to the p1 pole
    const int lat = r <= rings ? r : r - 1;   // the equator ring is doubled: one on each end
    const double phi = M_PI * lat / (2 * rings) - M_PI / 2;
    const Eigen::Vector3d centre = r <= rings ? p0 : p1;
    for (int s = 0; s < segments; ++s) {
      const double theta = 2 * M_PI * s / segments;
      m.vertices.push_back(
          centre + radius * (std::sin(phi) * axis + std::cos(phi) * (std::cos(theta) * u + std::sin(theta) * v)));
    }
  }
  const int n_rings = 2 * rings + 2;
  for (int r = 0; r + 1 < n_rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const int a = r * segments + s, b = r * segments + (s + 1) % segments;
      const int c = a + segments, d = b + segments;
      m.triangles.emplace_back(a, b, d);
      m.triangles.emplace_back(a, d, c);
    }
  return m;  // the pole rings are degenerate (zero-area triangles), which is harmless
}

EmulatedArm::EmulatedArm(const BcapEmulator& emulator, robot::ArmConfig arm)
    : emulator_(emulator), arm_(std::move(arm)) {
  for (const robot::LinkCapsule& c : robot::linkCapsules()) {
    links_.push_back(c.link);
    meshes_.push_back(capsuleMesh(c.p0, c.p1, c.radius));
  }
  for (const EffectorBody& e : effectorBodies(arm_.effector, arm_.T_flange_nozzle)) {
    links_.push_back(6);
    meshes_.push_back(transformed(cylinderMesh(e.radius, e.length, 16), e.T_flange_end()));
  }
}

ArmState EmulatedArm::update(double /*t*/) {
  const EmulatorJointState joints = emulator_.joints();
  const EmulatorToolState tool = emulator_.tool();
  ArmState state;
  state.nozzle_present = true;
  state.T_cell_nozzle = robot::forwardNozzle(arm_, joints.q);
  state.tool = tool.air ? Tool::kAir : tool.vacuum ? Tool::kVacuum : Tool::kOff;
  const std::vector<Pose> links = robot::linkPoses(joints.q);
  for (const int link : links_) state.T_cell_links.push_back(arm_.T_cell_base * links[link]);
  return state;
}

BcapEmulatorConfig emulatorConfig(const robot::ArmConfig& arm, int port, const std::string& bind_address,
                                  const std::string& vacuum_variable, const std::string& air_variable) {
  BcapEmulatorConfig c;
  c.bind_address = bind_address;
  c.port = port;
  c.q_min = arm.q_min;
  c.q_max = arm.q_max;
  c.qd_max = arm.qd_max;
  c.q_initial = arm.q_home;
  c.vacuum_variable = vacuum_variable;
  c.air_variable = air_variable;
  return c;
}

}  // namespace depowder::sim
