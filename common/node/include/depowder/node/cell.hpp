// The cell YAML (config/cell.yaml): the sections every process shares (lcm, box,
// cameras, parts) are read here; each module's own section (tracker, progress,
// planner, robot, sim, perception) is read by that module's executable from `root`.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/node/yaml.hpp"
#include "depowder/tool.hpp"

namespace depowder::node {

struct LcmConfig {
  std::string url;     ///< "" = $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0
  std::string prefix;  ///< put in front of every channel name
};

struct BoxConfig {
  Eigen::Vector3d size{0.40, 0.30, 0.20};  ///< interior x, y, z, metres; cell origin at the floor centre
  double wall = 0.01;                      ///< wall thickness, metres
};

/// Depth noise of a camera (the simulator applies it; a real camera has its own).
struct CameraNoise {
  double sigma_base = 0.0010;       ///< m, depth sigma at zero range
  double sigma_per_m = 0.0025;      ///< m of sigma added per metre of range (L515: ~5 mm at 1 m... 14 mm at 9 m)
  double flying_pixel_prob = 0.3;   ///< chance a depth-edge pixel returns a mixed depth
  double grazing_dropout_deg = 78;  ///< incidence beyond which returns start dropping out
  double dropout_prob = 0.002;      ///< random drop-out rate per pixel
};

struct CameraConfig {
  std::string name;  ///< DEPTH_<NAME> channel, upper-case recommended
  int width = 320;   ///< pixels (L515 modes: 320x240, 640x480, 1024x768)
  int height = 240;
  double fov_h_deg = 70;  ///< horizontal field of view (L515: 70)
  double fov_v_deg = 55;  ///< vertical field of view (L515: 55)
  double rate_hz = 30;
  double min_range = 0.25;                ///< m
  double max_range = 9.0;                 ///< m
  Pose T_cell_camera = Pose::Identity();  ///< camera frame: x right, y down, z forward
  CameraNoise noise;

  double fx() const;
  double fy() const;
  double cx() const { return 0.5 * (width - 1); }
  double cy() const { return 0.5 * (height - 1); }
};

struct PartConfig {
  std::string name;
  std::string mesh;                          ///< path, resolved against the YAML file's directory
  double mesh_scale = 1.0;                   ///< multiplies mesh coordinates (0.001 for millimetres)
  Pose T_cell_part_init = Pose::Identity();  ///< initial pose from the printer's build layout
  double xi = 0.01;       ///< template update distance threshold, m (paper: 1 cm; 0.8 cm propeller, pipe)
  double density = 1000;  ///< kg/m^3 of the printed material (PA12 ~1000)
};

struct CellConfig {
  std::string file;
  LcmConfig lcm;
  BoxConfig box;
  std::vector<CameraConfig> cameras;
  std::vector<PartConfig> parts;
  YamlReader root;  ///< for the module sections
};

/// Module sections a cell file may have (each read by its executable).
extern const std::vector<std::string> kModuleSections;

/// Reads and validates the shared sections. Throws ConfigError naming file, key and range.
CellConfig loadCell(const std::string& path);
CellConfig loadCellFromString(const std::string& text, const std::string& file = "<string>");

/// The part's mesh at its scale. Throws MeshError naming the part and the file (a cell of several
/// parts says which one is missing or broken).
Mesh loadPartMesh(const PartConfig& part);

/// A digest of the sections the processes share (box, cameras, parts: their values, and each
/// part's mesh file by its bytes), below 2^52: every process puts it in its heartbeat
/// (`cell_model`), so that on several hosts depowder-status can tell cell files that differ.
double cellModelId(const CellConfig& cell);

/// The tool as the cell file describes it for the planner and the driver, for the processes
/// that only draw or filter it (the viewer, the camera proxy's self-filter). The defaults are
/// planner::NozzleConfig's and robot::ArmConfig's.
struct ToolConfig {
  double nozzle_radius = kNozzleRadius;     ///< m, the nozzle tube (planner.nozzle.radius)
  double tube_length = kNozzleLength;       ///< m from the tip up its axis (planner.nozzle.length, grown to
                                            ///< robot.tool_offset's length as the planner grows it)
  Pose T_flange_nozzle = Pose::Identity();  ///< robot.tool_offset
  std::vector<EffectorSection> effector = vacuumEffector();  ///< from the flange (robot.effector), placed
                                                             ///< by effectorBodies(effector, T_flange_nozzle)
};
/// Reads planner.nozzle's radius and length, robot.tool_offset and robot.effector (each checked
/// by its own process as well). Throws ConfigError naming a key it cannot read.
ToolConfig readTool(const CellConfig& cell);

/// An end effector's body, `key` in `section` (robot.effector, perception.self_filter.effector):
/// a list of {radius, length} (m) from the flange towards the tip. Kept as is if absent.
void readEffector(const YamlReader& section, const std::string& key, std::vector<EffectorSection>& value);

using depowder::lookAt;  ///< camera pose at a position looking at a target (geometry.hpp)

/// Default config file: $DEPOWDER_CELL, else config/cell.yaml of the source tree.
std::string defaultCellPath();

/// The bus of a tool that only talks on it (depowder-estop, -monitor, -status): `url` and `prefix`
/// as given, else the `lcm` section of `cell` (read alone: a broken part or camera section cannot
/// keep an ESTOP off the bus), else of defaultCellPath(). A `cell` given that cannot be read throws
/// ConfigError; the default one is said on stderr (prefixed by `tool`) and the bus is the default.
LcmConfig toolBus(const std::string& tool, const std::string& cell, const std::optional<std::string>& url,
                  const std::optional<std::string>& prefix);

}  // namespace depowder::node
