// Rigid-body dynamics of the parts (Bullet, double precision; sim/README.md, "Physics"). The
// World owns one when `sim.physics.enabled`: each part is a dynamic body (a compound of convex
// hulls from its mesh, mass from its volume and density), the box floor and walls are static,
// the nozzle and the arm's links are kinematic bodies that push what they touch, and the
// powder holds, drags and topples the parts (powder_support.hpp). Parts under a scripted
// Motion (linear actuator, turntable) are kinematic too: moved, not simulated.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/sim/powder.hpp"
#include "depowder/sim/powder_support.hpp"
#include "depowder/sim/rigid_shape.hpp"
#include "depowder/sim/solid.hpp"

namespace depowder::sim {

struct BoxGeometry;
struct PartSpec;

struct PhysicsConfig {
  bool enabled = false;             ///< true: parts are rigid bodies; false: they stay where they are put
  double substep_hz = 1000;         ///< fixed physics steps per simulated second (World::step divides its dt)
  double gravity = 9.81;            ///< m/s^2, along -z
  double friction = 0.5;            ///< Coulomb friction, part-part and part-box (printed nylon on itself ~0.5)
  double nozzle_friction = 0.5;     ///< the nozzle's and links' friction on a part
  double restitution = 0.0;         ///< bounce (parts in powder do not bounce)
  double margin = 0.0005;           ///< m, the engine's collision margin (hulls are shrunk by it first)
  int solver_iterations = 20;       ///< the engine's contact solver iterations per substep
  double contact_distance = 0.001;  ///< m: a nozzle or link this close to a part touches it (SIM_TRUTH contact)
  double mass_voxel = 0.0015;       ///< m, voxel of the mass-property integration
  DecompositionConfig decomposition;
  PowderForceConfig powder;
};

/// A scripted part motion for the paper's Fig. 10 experiments. The part is moved, not simulated:
/// it holds its pose until `start`, moves until start + duration, then is released (physics) or
/// stays (no physics).
struct Motion {
  enum class Kind { kLinear, kTurntable };
  Kind kind = Kind::kLinear;
  Eigen::Vector3d velocity = Eigen::Vector3d(0.01, 0, 0);  ///< m/s, linear actuator, cell frame
  double rate = 0;                                         ///< rad/s, turntable (counter-clockwise seen from above)
  std::optional<Eigen::Vector2d> centre;  ///< m, cell xy of the turntable's axis; unset: the part's bounding-box centre
  double start = 0;                       ///< s of simulated time the motion starts
  double duration = std::numeric_limits<double>::infinity();  ///< s
  double visibility = -1;  ///< >= 0: the crater is re-dug to this true eta every step (a set visibility);
                           ///< < 0: the part ploughs through the powder like any moving part
};

/// The pose at time t of a part that started the motion at T_start (the centre resolved).
Pose motionPose(const Motion& motion, const Pose& T_start, const Eigen::Vector2d& centre, double t);

struct PhysicsStats {
  long substeps = 0;  ///< since the start
  int hulls = 0;      ///< convex pieces of all parts
};

class Physics {
 public:
  /// `solids`: the parts' point-in-solid tests (the World's), same order as `parts`.
  Physics(const PhysicsConfig& config, const BoxGeometry& box, const std::vector<PartSpec>& parts,
          const std::vector<const PartSolid*>& solids);
  ~Physics();
  Physics(const Physics&) = delete;
  Physics& operator=(const Physics&) = delete;

  /// The nozzle's collision shape: the convex hull of its mesh (nozzle frame).
  void setNozzleMesh(const Mesh& mesh);
  /// The arm links' collision shapes: convex hulls (link frames).
  void setArmLinks(const std::vector<Mesh>& link_meshes);

  /// Puts a part at a pose, at rest (setPartPose).
  void teleport(std::size_t part, const Pose& T_cell_part);
  /// Scripted (kinematic, moved by `step`'s targets) or free (dynamic, at rest from here).
  void setScripted(std::size_t part, bool scripted);

  struct StepInput {
    bool nozzle_present = false;
    Pose T_cell_nozzle = Pose::Identity();     ///< at the end of the step (interpolated from the last)
    std::vector<Pose> T_cell_links;            ///< at the end of the step; empty: no links
    std::vector<std::optional<Pose>> targets;  ///< per part: the scripted pose at the end of the step
    const PowderField* powder = nullptr;
    double repose_deg = 32;                                           ///< the powder's angle of repose
    std::function<bool(std::size_t part, std::size_t cell)> covered;  ///< cell is under the part
  };
  /// Advances dt seconds in fixed substeps.
  void step(double dt, const StepInput& input);

  Pose pose(std::size_t part) const;
  /// The nozzle or a link touched the part during the last step.
  bool touching(std::size_t part) const;
  const MassProperties& massProperties(std::size_t part) const;
  const std::vector<ConvexPiece>& pieces(std::size_t part) const;
  const PhysicsStats& stats() const;
  const PhysicsConfig& config() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace depowder::sim
