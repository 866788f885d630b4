// depowder-sim's configuration: the cell YAML (box, cameras, parts) plus its `sim`
// section, read into the library's plain structs. Executables, tests and benchmarks
// share this; the library itself never sees YAML.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "depowder/node/cell.hpp"
#include "depowder/sim/push.hpp"
#include "depowder/sim/script.hpp"
#include "depowder/sim/world.hpp"

namespace depowder::sim {

struct SimSetup {
  std::string cell_file;  ///< the cell file the box, cameras and parts came from
  std::string sim_file;   ///< the file the sim section came from (the cell file or a scenario overlay)
  node::LcmConfig lcm;
  SimConfig config;
  BoxGeometry box;
  std::vector<PartSpec> parts;
  std::vector<CameraModel> cameras;
  std::uint32_t seed = 1;       ///< noise seed
  double step_hz = 120;         ///< world steps per simulated second
  double truth_hz = 30;         ///< SIM_TRUTH messages per simulated second
  std::string visibility_part;  ///< if set: dig around this part to visibility_eta at the start
  double visibility_eta = 0;
  std::string nozzle_mesh;  ///< if set: this mesh replaces the cylinder (loaded at run time)
  double nozzle_mesh_scale = 0.001;
  Pose T_nozzle_mesh = Pose::Identity();
  std::vector<ScriptSegment> script;
  bool script_loop = true;
  std::string arm = "script";               ///< what moves the nozzle: "script" or "emulator" (the b-CAP controller)
  std::string emulator_bind = "127.0.0.1";  ///< address the b-CAP emulator listens on (0.0.0.0: every interface)
  struct PartMotion {
    std::string part;
    Motion motion;
  };
  std::vector<PartMotion> motions;  ///< sim.motions: scripted part motions (linear actuator, turntable)
  struct Push {
    std::string part;
    double azimuth_deg = 180;  ///< side the nozzle comes from (0: +x, counter-clockwise from above)
    double height = 0.5;       ///< contact height, 0 = the part's bottom, 1 = its top
    double offset = 0;         ///< m off the part's centre, to the left of the push direction
    PushSpec spec;             ///< speeds, gaps (the contact point and direction come from the three above)
  };
  std::optional<Push> push;  ///< sim.push: the nozzle pushes a part to the box edge (with arm: script)
  /// sim.faults: what goes wrong in the cell, and when (fault tests; the README's fault list).
  struct Fault {
    double at = 0;                 ///< simulated seconds
    std::string silence_camera;    ///< this camera publishes nothing from `at` for `duration` (cable pulled)
    double duration = 0;           ///< s
    bool drop_controller = false;  ///< the b-CAP emulator drops every connection at `at` (needs arm: emulator)
  };
  std::vector<Fault> faults;
};

/// Why the setup's faults cannot run with its arm, "" if they can: a controller drop needs the
/// emulator. Checked when the sim section is read and again when --arm overrides its choice.
std::string faultsProblem(const SimSetup& setup);

/// The simulated camera of a cell camera: the same intrinsics, range, rate and noise.
CameraModel cameraModelOf(const node::CameraConfig& c);

/// The setup of an already loaded cell file, its own sim section included (as loadSimSetup without
/// a scenario). Loads the part meshes; throws node::ConfigError or MeshError.
SimSetup simSetupOf(const node::CellConfig& cell);

/// Reads `cell_path`; `scenario_path` (optional) is either a full cell file used instead, or a file
/// holding only a `sim:` section that replaces the cell's. Loads the part meshes. Throws
/// node::ConfigError (file, key, range) or MeshError (file).
SimSetup loadSimSetup(const std::string& cell_path, const std::string& scenario_path = "");

/// The world of a setup, with its start-up visibility, nozzle mesh and part motions applied.
std::unique_ptr<World> makeWorld(const SimSetup& setup);

/// The push of sim.push on `world` (null without one): an ArmSource that replaces the script.
std::unique_ptr<PushScript> makePushScript(const SimSetup& setup, const World& world);

}  // namespace depowder::sim
