// The arm of the simulated cell as the b-CAP controller emulator moves it: the
// emulator's joint angles through the VS-6577 kinematics give the nozzle pose and
// the link poses (drawn as occluders, tested for contact), its I/O the tool.
// depowder-driver reaches the emulator over b-CAP exactly as it would a real RC8.
#pragma once

#include <vector>

#include "depowder/mesh.hpp"
#include "depowder/robot/kinematics.hpp"
#include "depowder/sim/bcap_emulator.hpp"
#include "depowder/sim/script.hpp"

namespace depowder::sim {

class EmulatedArm : public ArmSource {
 public:
  EmulatedArm(const BcapEmulator& emulator, robot::ArmConfig arm);
  /// One closed mesh per link capsule and one for the end effector's body (link frame), for
  /// World::setArmLinks. The world draws and tests the nozzle tube itself.
  const std::vector<Mesh>& linkMeshes() const { return meshes_; }
  ArmState update(double t) override;

 private:
  const BcapEmulator& emulator_;
  robot::ArmConfig arm_;
  std::vector<int> links_;  ///< the link each mesh rides on (robot::linkPoses)
  std::vector<Mesh> meshes_;
};

/// A closed capsule mesh around the segment p0-p1 (m), `segments` around its axis.
Mesh capsuleMesh(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, double radius, int segments = 12);

/// The emulator's configuration from the arm and the controller's I/O names.
BcapEmulatorConfig emulatorConfig(const robot::ArmConfig& arm, int port, const std::string& bind_address,
                                  const std::string& vacuum_variable, const std::string& air_variable);

}  // namespace depowder::sim
