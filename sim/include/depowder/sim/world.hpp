// The simulated cell: a build box of powder with parts in it, a nozzle (and later the
// arm's links), and virtual depth cameras. Pure library (no LCM, YAML or file IO): the
// depowder-sim executable, the evaluation tool and the benchmarks drive it in process,
// as fast as they like:
//
//   World world(config, box, {{"pipe", parts::pipe(), T_cell_part}}, {camera});
//   world.digToVisibility(0, 0.6);               // or leave the paper's initial cover
//   world.setNozzle(T_cell_nozzle, Tool::kVacuum);
//   world.step(1.0 / 120);
//   DepthImage frame = world.render(0);          // the camera's own seeded noise stream
//   Truth truth = world.truth();                 // poses, Eq. 2 eta, contacts, powder removed
//
// Parts may be moved every step (setPartPose): the powder's floor follows. With
// `physics.enabled` the parts are rigid bodies (physics.hpp): gravity, the powder's support and
// drag, the box, and the nozzle and arm links pushing them; they move in step() and push the
// powder aside (movePart). Scripted motions (setPartMotion: linear actuator, turntable) move a
// part kinematically, with or without physics.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/sim/camera.hpp"
#include "depowder/sim/nozzle.hpp"
#include "depowder/sim/physics.hpp"
#include "depowder/sim/powder.hpp"
#include "depowder/sim/raster.hpp"
#include "depowder/sim/script.hpp"
#include "depowder/sim/solid.hpp"

namespace depowder::sim {

struct TruthConfig {
  double band_inner = 0.010;  ///< m from the part's footprint to the start of the Eq. 2 powder band (authors: xi)
  double band_outer = 0.015;  ///< m from the footprint to its end (authors: xi + 0.5 cm)
};

struct SceneConfig {
  double depth_unit = 0.00025;     ///< m per depth count (L515: 0.25 mm)
  double table_size = 1.5;         ///< m, side of the table top the box stands on (0: no table)
  double contact_spacing = 0.004;  ///< m between the nozzle's (and links') contact sample points
  double solid_column = 0.001;     ///< m, column spacing of the parts' point-in-solid test
};

struct SimConfig {
  PowderConfig powder;
  VacuumConfig vacuum;
  AirConfig air;
  NozzleGeometry nozzle;
  TruthConfig truth;
  SceneConfig scene;
  PhysicsConfig physics;  ///< rigid-body dynamics of the parts (off by default in the library)
};

struct BoxGeometry {
  Eigen::Vector3d size{0.40, 0.30, 0.20};  ///< m, interior; the cell origin is the centre of its floor
  double wall = 0.01;                      ///< m
};

struct PartSpec {
  std::string name;
  Mesh mesh;                            ///< part frame, metres
  Pose T_cell_part = Pose::Identity();  ///< initial pose
  double density = 1000;                ///< kg/m^3 of the printed material (physics: mass = volume x density)
};

struct PartTruth {
  std::string name;
  Pose T_cell_part = Pose::Identity();
  double eta = 0;               ///< Eq. 2 on the true powder surface, in [0, 1]
  double h_pow = 0;             ///< m, mean surface height over the band cells (before clamping)
  double h_max = 0;             ///< m, top of the posed mesh
  double h_min = 0;             ///< m, bottom of the posed mesh
  int band_cells = 0;           ///< powder cells in the band (0: eta is 0 and meaningless)
  bool nozzle_contact = false;  ///< the nozzle (or an arm link) is inside the part now
  double speed = 0;             ///< m/s of the part origin over the last step
  double angular_speed = 0;     ///< rad/s of the part's rotation over the last step
};

struct Truth {
  double time = 0;  ///< s of simulated time
  std::vector<PartTruth> parts;
  Pose T_cell_nozzle = Pose::Identity();
  Tool tool = Tool::kOff;
  double powder_removed_m3 = 0;  ///< by the tools since the start
  double powder_volume_m3 = 0;   ///< powder above the floors now
  int contact_count = 0;         ///< nozzle/arm-part contact events (a contact starting) since the start
};

class World {
 public:
  /// Parts start at their poses, buried: the surface is `powder.level`, or `powder.cover` above the
  /// highest part top (the paper's initial state). `seed` seeds each camera's noise stream.
  World(const SimConfig& config, const BoxGeometry& box, std::vector<PartSpec> parts, std::vector<CameraModel> cameras,
        std::uint32_t seed = 1);

  // --- driving the world ---
  void setNozzle(const Pose& T_cell_nozzle, Tool tool);
  /// Takes the nozzle out of the cell (not drawn, no tool, no contact).
  void removeNozzle();
  /// Replaces the cylinder by another mesh in the nozzle frame (tip at the origin, +z = spray direction).
  void setNozzleMesh(Mesh mesh, bool closed_outward = false);
  /// The arm's link meshes (link frames), set once; then their poses every step. Drawn as occluders and
  /// tested for contact.
  void setArmLinks(std::vector<Mesh> link_meshes);
  void setArmLinkPoses(const std::vector<Pose>& T_cell_link);
  /// The arm for the coming step (an ArmSource's state): the nozzle set or taken out, and the
  /// link poses when it carries any.
  void setArm(const ArmState& arm);
  /// Moves a part (scripted motion, physics). The powder's floor follows at once. With physics, the
  /// part's body is put there at rest.
  void setPartPose(std::size_t part, const Pose& T_cell_part);
  /// Moves a part as the physics does, pushing the powder: in each column the powder the part moves
  /// into goes up (onto the part: piles up in front, then slides off), and where it leaves, the powder
  /// above falls into the gap (spreads behind); the column's powder volume is kept (a gap opened
  /// under a part lifting out of the powder is not represented). The floors follow.
  void movePart(std::size_t part, const Pose& T_cell_part);
  /// A scripted motion (paper Fig. 10): from now on the part is moved, not simulated (kinematic: it
  /// pushes other parts, nothing pushes it). It holds until motion.start (a start in the past means
  /// now), moves until start + duration, then is released (physics: a free body at rest).
  /// Throws std::invalid_argument naming the part for a part that does not exist or a motion with
  /// a non-finite velocity, rate, centre or start, or a negative or NaN duration.
  void setPartMotion(std::size_t part, const Motion& motion);
  /// Ends a scripted motion now (the part stays where it is, free again).
  void clearPartMotion(std::size_t part);
  bool hasPartMotion(std::size_t part) const { return parts_.at(part).motion.has_value(); }
  /// Advances the parts (motions, physics), the tools, the powder relaxation and the contacts by dt seconds.
  void step(double dt);

  // --- powder set-up ---
  /// A flat surface at `level` (m), never inside a part.
  void setPowderLevel(double level);
  /// Digs a crater around `part` so that its true eta is `eta` (the static experiment: a part at a set
  /// visibility): the surface drops to H = H_max - eta (H_max - H_min) over the footprint and to beyond the
  /// band, then rises back at just under the angle of repose, so relaxation leaves it alone.
  void digToVisibility(std::size_t part, double eta);

  // --- sensing ---
  /// A frame of camera `camera` with its own seeded noise stream.
  DepthImage render(std::size_t camera);
  /// A frame with noise drawn from `rng`, or noise-free if rng is nullptr.
  DepthImage render(std::size_t camera, std::mt19937* rng);
  Truth truth() const;
  PartTruth partTruth(std::size_t part) const;

  // --- access ---
  double time() const { return time_; }
  std::int64_t steps() const { return steps_; }
  const PowderField& powder() const { return powder_; }
  /// Direct access for tests and set-ups (heights may be edited; relaxation picks the change up).
  PowderField& powder() { return powder_; }
  const std::vector<CameraModel>& cameras() const { return cameras_; }
  const BoxGeometry& box() const { return box_; }
  const SimConfig& config() const { return config_; }
  std::size_t partCount() const { return parts_.size(); }
  const PartSpec& part(std::size_t i) const { return parts_.at(i).spec; }
  /// Index of the part called `name`; throws std::invalid_argument naming the known parts.
  std::size_t partIndex(const std::string& name) const;
  /// All the powder in the box, m^3: above the floors and hidden under the parts (each column's
  /// surface height less the parts below it). Moving parts keep it, but for the gaps noted at movePart.
  double powderInBox() const;
  /// Powder removed by the tools since the start, m^3 (cheap; truth() also has it).
  double powderRemoved() const { return removed_; }
  const Pose& nozzlePose() const { return T_cell_nozzle_; }
  /// The rigid-body engine, or null when config().physics.enabled is false.
  const Physics* physics() const { return physics_.get(); }
  Tool tool() const { return tool_; }
  bool nozzlePresent() const { return nozzle_present_; }

 private:
  struct PartState {
    PartSpec spec;
    PartSolid solid;
    std::vector<double> top, bottom;  ///< envelope over the powder cells (-inf / +inf: not over the part)
    std::vector<std::size_t> band;    ///< powder cells of the Eq. 2 band
    double h_max = 0, h_min = 0;
    Pose T_last = Pose::Identity();  ///< pose at the end of the last step
    double speed = 0, angular_speed = 0;
    bool contact = false;
    Pose T_geometry = Pose::Identity();        ///< the pose top/bottom/band were computed for
    int fi0 = 0, fi1 = -1, fj0 = 0, fj1 = -1;  ///< cell bounds of the footprint (empty if fi0 > fi1)
    struct Scripted {
      Motion motion;
      Pose T_start = Pose::Identity();
      Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    };
    std::optional<Scripted> motion;
  };
  void updatePartGeometry(PartState& part);
  void updateFloor();
  void updateContacts();
  void buildPowderMesh();
  /// Motions and physics for one step.
  void advanceParts(double dt);
  /// Sets the parts' poses; the powder is displaced by those with displace[i] (movePart).
  void moveParts(const std::vector<Pose>& poses, const std::vector<bool>& displace);
  /// digToVisibility within `margin` cells of the part's footprint.
  void digAround(std::size_t part, double eta, int margin);

  SimConfig config_;
  BoxGeometry box_;
  PowderField powder_;
  std::vector<PartState> parts_;
  std::vector<CameraModel> cameras_;
  std::vector<std::mt19937> rngs_;
  std::vector<std::int64_t> frames_;
  std::vector<DepthRasterizer> rasterizers_;

  Mesh box_mesh_, table_mesh_;
  Mesh nozzle_mesh_;
  bool nozzle_closed_ = true;
  Cloud nozzle_samples_;
  Pose T_cell_nozzle_ = Pose::Identity();
  Tool tool_ = Tool::kOff;
  bool nozzle_present_ = false;
  std::vector<Mesh> link_meshes_;
  std::vector<Cloud> link_samples_;
  std::vector<Pose> T_cell_links_;

  // The powder surface as triangles (cell-frame vertices), rebuilt when the field changes.
  std::vector<Eigen::Vector3f> powder_vertices_;
  std::vector<std::uint32_t> powder_indices_;
  std::uint64_t powder_mesh_version_ = ~0ull;

  std::unique_ptr<Physics> physics_;

  double time_ = 0;
  std::int64_t steps_ = 0;
  double removed_ = 0;
  int contact_count_ = 0;
};

}  // namespace depowder::sim
