// Planner settings: one plain struct with a default and a unit on every field. The YAML
// keys of the `planner:` section of the cell file mirror these names (config/cell.yaml).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "depowder/tool.hpp"

namespace depowder::planner {

/// The cleaning nozzle: a cylinder above its tip. Nozzle frame: tip at the origin, +z is the
/// spray / suction direction (pointing down, -z of the cell, while vacuuming and blasting).
struct NozzleConfig {
  double radius = kNozzleRadius;  ///< m (the nozzle is about 2.5 cm in diameter)
  double length = kNozzleLength;  ///< m of nozzle body above the tip
  double margin = 0.0025;         ///< m added around the nozzle in every collision check
};

/// Phases 1-2 (paper Sec. III-B): a closed loop around the part that removes one powder layer.
struct VacuumConfig {
  double standoff = 0.025;             ///< m, nozzle axis to the part surface (authors: 2.0-2.5 cm)
  double layer_depth = 0.005;          ///< m the tip runs below the powder height: one layer per loop
  double speed = 0.03;                 ///< m/s of the tip along the loop
  double spacing = 0.01;               ///< m between waypoints along the loop
  double min_tip_height = 0.005;       ///< m above the box floor
  double standoff_tolerance = 0.0005;  ///< m, how exactly a waypoint is put at the stand-off
  int min_contour_points = 8;          ///< fewer contour points: the loop is built from the footprint
  bool counter_clockwise = true;       ///< loop direction seen from above
  /// m the loops may go below the part's lowest point. 0: they stop at its bottom. More: the
  /// powder the part was printed on is dug away too, in phase 2 and, before the air blast, in
  /// phase 3 until the powder beside the part is this deep (a perched part then loses its
  /// support and may topple: paper Fig. 2).
  double undercut = 0.0;
};

/// Phase 3: a boustrophedon raster over the part's footprint from the top, tool AIR.
struct BlastConfig {
  double standoff = 0.03;  ///< m of tip above the part surface below the nozzle
  double spacing = 0.015;  ///< m between raster lines
  double step = 0.01;      ///< m between waypoints along a line
  double overhang = 0.01;  ///< m the raster reaches beyond the footprint
  double speed = 0.05;     ///< m/s
};

/// Collision checking (FCL) of the nozzle and arm links against parts, box and powder.
struct CollisionConfig {
  double tracking_margin = 0.005;  ///< m parts are inflated by (tracking uncertainty)
  double lost_margin = 0.02;       ///< m a LOST part is inflated by (its last pose is doubtful)
  double arm_margin = 0.01;        ///< m around the arm links
  double push_step = 0.002;        ///< m per outward push of a colliding waypoint
  double max_push = 0.02;          ///< m; a waypoint still colliding after this is dropped
  double edge_step = 0.005;        ///< m of tip travel between checks along a path edge
  double max_joint_step = 0.3;     ///< rad between IK points along an edge (the driver refuses > 0.35)
  /// The nozzle tip must stay in this box, cell frame (the driver's robot.workspace, less its margin).
  Eigen::Vector3d workspace_min{-0.195, -0.145, 0.0};  ///< m
  Eigen::Vector3d workspace_max{0.195, 0.145, 0.595};  ///< m
};

/// Moves between path segments, parts and home: joint-space RRTConnect + simplification.
struct TransitionConfig {
  double time_limit = 0.5;         ///< s per OMPL query (solve + simplify)
  double clearance = 0.03;         ///< m above the highest part / powder the nozzle lifts to
  double speed = 0.10;             ///< m/s of the tip during transitions (tool off)
  double check_resolution = 0.02;  ///< rad, longest joint-space step between validity checks
  double waypoint_step = 0.1;      ///< rad, longest joint-space step between sent waypoints
  double direct_move = 0.02;       ///< m; closer than this the path is entered directly
  std::uint32_t seed = 1;          ///< OMPL random seed (reproducible plans)
};

/// When to plan again and what counts as stale.
struct ReplanConfig {
  double translation = 0.005;  ///< m the pose must move to regenerate the path
  double rotation_deg = 3.0;   ///< deg the pose must turn to regenerate the path
  double stale_s = 1.0;        ///< s a pose may lag behind the newest frame before holding
  /// s; a running plan is re-sent (its remaining waypoints, stamped with the newest frame) when
  /// it is older than this, because the driver stops a plan older than robot.plan_max_age (1.5 s).
  double refresh_s = 0.5;
  /// s; > 0: a tracked part whose pose has moved by more than moving_translation or
  /// moving_rotation_deg within this time is moving (it topples, or is pushed): the nozzle goes
  /// home and waits until every part has kept still this long, then plans around the new pose
  /// (paper Fig. 2). 0: off (the nozzle only backs away from a part that enters its margins).
  double settle_s = 0.0;
  double moving_translation = 0.01;  ///< m
  double moving_rotation_deg = 5.0;  ///< deg
};

struct PlannerConfig {
  NozzleConfig nozzle;
  VacuumConfig vacuum;
  BlastConfig blast;
  CollisionConfig collision;
  TransitionConfig transition;
  ReplanConfig replan;
};

/// The build box: cell origin at the centre of its floor, z up.
struct Box {
  Eigen::Vector3d size{0.40, 0.30, 0.20};  ///< interior x, y, z, m
  double wall = 0.01;                      ///< wall and floor thickness, m
};

}  // namespace depowder::planner
