// Collision checking of the nozzle (and, with an arm model, the VS-6577 links) against
// the parts at their estimated poses, the build box and the powder. FCL lives behind
// the pimpl: part meshes are BVHModel<OBBRSS>, walls and floor are boxes, the nozzle is
// a cylinder. A margin is added by inflating the moving shapes (a cylinder or box grown
// by m contains every point within m of the original), so each check is a boolean
// collide, not a distance query.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/planner/config.hpp"
#include "depowder/robot/kinematics.hpp"

namespace depowder::planner {

/// One part's mesh with its bounding-volume hierarchy, built once (a few ms) and shared.
class PartShape {
 public:
  PartShape(std::string name, Mesh mesh);
  ~PartShape();

  const std::string& name() const { return name_; }
  const Mesh& mesh() const { return mesh_; }
  /// Surface samples (part frame, about 3 mm apart), for footprints and height maps.
  const Cloud& samples() const { return samples_; }

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::string name_;
  Mesh mesh_;
  Cloud samples_;
  std::unique_ptr<Impl> impl_;
};

/// How a part takes part in collision checks.
enum class PartState {
  kTracked,  ///< at its estimated pose, inflated by tracking_margin
  kLost,     ///< at its last pose, inflated by lost_margin
  kIgnored,  ///< not an obstacle (not in the cell)
};

/// What a check hit, if anything.
struct Contact {
  bool collision = false;
  std::string what;  ///< e.g. "nozzle-part:cube", "link3-wall:+x"; "" when free
  int part = -1;     ///< the part's index when the arm or nozzle touches a part
  explicit operator bool() const { return collision; }
};

/// What a check includes. Converts from a bool (the powder flag).
struct CheckOptions {
  bool powder = false;      ///< the powder is an obstacle (transitions); vacuum paths run inside it
  bool lost_margin = true;  ///< false: LOST parts with the tracked margin (leaving along the nozzle axis)
  int ignore_part = -1;     ///< a part index left out (an escape move checks that part separately)
  CheckOptions(bool powder_ = false, bool lost_margin_ = true, int ignore_part_ = -1)  // NOLINT: implicit by design
      : powder(powder_), lost_margin(lost_margin_), ignore_part(ignore_part_) {}
};

class CollisionWorld {
 public:
  /// `arm` may be null: then only the nozzle can be checked (checkArm needs it). The arm's
  /// link capsules come from robot::linkCapsules; its "tool" capsule is replaced by the
  /// nozzle cylinder of `nozzle` (grown to reach the flange if the tool offset is longer).
  CollisionWorld(std::vector<std::shared_ptr<const PartShape>> parts, const Box& box, const NozzleConfig& nozzle,
                 const CollisionConfig& config, std::shared_ptr<const robot::ArmConfig> arm = nullptr);
  ~CollisionWorld();
  CollisionWorld(const CollisionWorld&) = delete;
  CollisionWorld& operator=(const CollisionWorld&) = delete;

  std::size_t numParts() const;
  const PartShape& part(std::size_t i) const;
  void setPart(std::size_t i, const Pose& T_cell_part, PartState state);
  const Pose& partPose(std::size_t i) const;
  PartState partState(std::size_t i) const;

  /// The powder as an obstacle for transitions: the box interior from the floor up to
  /// `top` (m, cell z); a value <= 0 removes it. It counts only in checks with options.powder.
  void setPowderTop(double top);
  double powderTop() const;

  /// The nozzle alone at T_cell_nozzle.
  Contact checkNozzle(const Pose& T_cell_nozzle, const CheckOptions& options = {}) const;

  /// Links and nozzle at joint angles q: joint limits, links against box, powder and parts
  /// (margin arm_margin, plus the part's margin), the nozzle as in checkNozzle, and the
  /// nozzle against the base, turret, upper arm and elbow (self collision).
  Contact checkArm(const robot::Joints& q, const CheckOptions& options = {}) const;
  /// The arm model (throws std::logic_error if there is none).
  const robot::ArmConfig& arm() const;

  const Box& box() const;
  const NozzleConfig& nozzle() const;
  const CollisionConfig& config() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace depowder::planner
