// The nozzle pushing a part through the powder to the box edge (paper Sec. V-C, Table II: "we use
// the robotic arm to push the part until it reaches the box edge"). An ArmSource: the World's
// main loop (or a tool) asks it for the nozzle each step; it reads the part's pose from the
// World to know when the part has reached the wall. Needs sim.physics.enabled (otherwise the
// nozzle only passes through the part and the push ends at the nozzle's own limit).
//
//   PushScript push(world, pushFrom(world, part, 180, 0.5));   // from -x, half height, toward the centre
//   for (double t = dt; push.phase() != PushPhase::kDone; t += dt) {
//     const ArmState a = push.update(t);
//     world.setNozzle(a.T_cell_nozzle, a.tool);
//     world.step(dt);
//   }
#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "depowder/sim/script.hpp"

namespace depowder::sim {

class World;

struct PushSpec {
  std::size_t part = 0;
  Eigen::Vector3d contact_part = Eigen::Vector3d::Zero();  ///< m, contact point on the part, part frame (at the start)
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();    ///< push direction, cell frame (its horizontal part is used)
  double speed = 0.02;                                     ///< m/s along `direction` while pushing
  double approach_speed = 0.05;                            ///< m/s descending to the contact height and retracting
  double clearance = 0.03;  ///< m above the part's top (and the powder) where the nozzle comes in and leaves
  double gap = 0.005;       ///< m between the nozzle's side and the part before the push (the nozzle starts
                            ///< further back along the push line where an edge or oblique face is nearer)
  double tip_below = 0.01;  ///< m the tip goes below the contact point (so the nozzle's side meets it)
  double wall_gap = 0.003;  ///< m: the part has reached the wall when its bounds are this close to it
  double stall_time = 3;    ///< s without the part moving 1 mm: the push gives up (jammed)
  double settle = 0.5;      ///< s the nozzle stays at the end before retracting
  bool steer = true;        ///< steer sideways toward the part's centre, so a part an off-centre contact
                            ///< turned is still pushed on to the wall (false: a straight line)
};

enum class PushPhase { kDescend, kPush, kSettle, kRetract, kDone };
const char* toString(PushPhase phase);

/// How a push ended (valid once the phase is past kPush).
enum class PushOutcome { kRunning, kReachedWall, kNozzleAtWall, kStalled };
const char* toString(PushOutcome outcome);

class PushScript : public ArmSource {
 public:
  /// The world must outlive the script; its part's pose at construction sets the start.
  PushScript(const World& world, const PushSpec& spec);
  ArmState update(double t) override;

  PushPhase phase() const { return phase_; }
  PushOutcome outcome() const { return outcome_; }
  const PushSpec& spec() const { return spec_; }
  /// m the nozzle travelled while pushing.
  double pushed() const { return pushed_; }

 private:
  bool partAtWall() const;
  bool nozzleAtWall() const;

  const World& world_;
  PushSpec spec_;
  Eigen::Vector3d dir_;   ///< unit, horizontal
  Eigen::Vector3d side_;  ///< unit, horizontal, dir_ rotated +90 deg
  Eigen::Vector3d tip_;   ///< current tip position
  double push_z_ = 0, high_z_ = 0;
  PushPhase phase_ = PushPhase::kDescend;
  PushOutcome outcome_ = PushOutcome::kRunning;
  double last_t_ = 0, phase_start_ = 0, pushed_ = 0;
  Eigen::Vector3d progress_origin_;  ///< part position when it last moved 1 mm
  double progress_time_ = 0;
};

/// A push from the side: a horizontal ray toward the part's centre (the bounding-box centre of the
/// posed part) from azimuth `azimuth_deg` (0: from +x, counter-clockwise seen from above), at
/// `height` (0: the part's bottom, 1: its top) and shifted by `offset` m to the left of the push
/// direction (an off-centre push turns the part: left of centre, clockwise seen from above); the
/// contact point is where the ray first meets the mesh, the direction the ray's.
/// Throws std::invalid_argument if the ray misses the part.
PushSpec pushFrom(const World& world, std::size_t part, double azimuth_deg, double height, double offset = 0);

}  // namespace depowder::sim
