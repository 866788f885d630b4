// What moves the nozzle. The sim's main loop asks an ArmSource once per step; today that
// is a scripted trajectory (waypoints, or an orbit around a part like the paper's static
// test, Sec. V-B), later the b-CAP controller emulator driven by depowder-driver.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/sim/nozzle.hpp"

namespace depowder::sim {

/// The arm as the world needs it for one step.
struct ArmState {
  bool nozzle_present = false;  ///< false: no nozzle in the cell (parked out of view)
  Pose T_cell_nozzle = Pose::Identity();
  Tool tool = Tool::kOff;
  std::vector<Pose> T_cell_links;  ///< one per arm link mesh given to World::setArmLinks (empty: none)
};

class ArmSource {
 public:
  virtual ~ArmSource() = default;
  /// The state at simulated time t (s); called once per step, t increasing.
  virtual ArmState update(double t) = 0;
};

/// Nozzle frame: tip at the origin, +z the spray direction. "Pointing down" = z along -z of the cell.
struct Waypoint {
  double t = 0;  ///< s from the start of its segment (increasing)
  Pose T_cell_nozzle = Pose::Identity();
  Tool tool = Tool::kOff;  ///< while travelling to this waypoint and at it (like waypoint_t)
};

/// The nozzle circles an ellipse at a height, pointing down (or leaning its spray toward the centre).
struct Orbit {
  Eigen::Vector2d centre{0, 0};       ///< m, cell xy
  Eigen::Vector2d radii{0.06, 0.06};  ///< m, semi-axes along cell x and y
  double height = 0.15;               ///< m, tip height at the segment start
  double period = 8;                  ///< s per revolution (counter-clockwise from above)
  double start_deg = 0;               ///< deg, angle at the segment start (0 = +x)
  double tilt_deg = 0;                ///< deg the spray axis leans from straight down toward the centre
  double descend_per_rev = 0;         ///< m the tip goes down per revolution
  double min_height = 0;              ///< m, the tip goes no lower
  double revolutions = 1;             ///< segment length
  Tool tool = Tool::kOff;
};

struct ScriptSegment {
  enum class Kind { kWaypoints, kOrbit };
  Kind kind = Kind::kWaypoints;
  std::vector<Waypoint> waypoints;  ///< kWaypoints: at least one
  Orbit orbit;                      ///< kOrbit
  double duration() const;          ///< s
};

/// Segments played one after the other, then repeated (`loop`) or the last state held.
/// No segments: the nozzle stays out of the cell.
class NozzleScript : public ArmSource {
 public:
  NozzleScript() = default;
  NozzleScript(std::vector<ScriptSegment> segments, bool loop);
  ArmState update(double t) override { return at(t); }
  ArmState at(double t) const;
  double duration() const { return duration_; }

 private:
  std::vector<ScriptSegment> segments_;
  bool loop_ = false;
  double duration_ = 0;
};

/// A nozzle pose with the tip at `tip` and the spray axis along `spray` (need not be unit).
Pose nozzlePose(const Eigen::Vector3d& tip, const Eigen::Vector3d& spray);

}  // namespace depowder::sim
