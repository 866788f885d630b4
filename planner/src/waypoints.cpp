#include "depowder/planner/waypoints.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

namespace depowder::planner {

Waypoint atJoints(const robot::ArmConfig& arm, const robot::Joints& q, Tool tool, double speed) {
  Waypoint w;
  w.T_cell_nozzle = robot::forwardNozzle(arm, q);
  w.tool = tool;
  w.speed = speed;
  w.q = q;
  return w;
}

double travelSeconds(const std::vector<Waypoint>& waypoints) {
  double t = 0;
  for (std::size_t i = 1; i < waypoints.size(); ++i)
    if (waypoints[i].speed > 0)
      t += (waypoints[i].T_cell_nozzle.translation() - waypoints[i - 1].T_cell_nozzle.translation()).norm() /
           waypoints[i].speed;
  return t;
}

Pose nozzleDown(const robot::ArmConfig& arm, const Point& tip) {
  Eigen::Vector3d x = tip - arm.T_cell_base.translation();
  x.z() = 0;
  if (x.norm() < 1e-9) x = arm.T_cell_base.linear().col(0);
  x.z() = 0;
  x.normalize();
  const Eigen::Vector3d z(0, 0, -1);
  Pose T = Pose::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = tip;
  return T;
}

std::string PathReport::summary() const {
  std::string s = std::to_string(kept) + "/" + std::to_string(input) + " waypoints kept, " + std::to_string(pushed) +
                  " pushed, " + std::to_string(dropped) + " dropped for collision";
  if (!first_contact.empty()) s += " (" + first_contact + ")";
  s += ", " + std::to_string(unreachable) + " unreachable";
  if (cuts > 0) s += ", " + std::to_string(cuts) + " cuts";
  return s;
}

std::size_t RefinedPath::size() const {
  std::size_t n = 0;
  for (const auto& p : pieces) n += p.size();
  return n;
}

namespace {

double maxJointStep(const robot::Joints& a, const robot::Joints& b) {
  double m = 0;
  for (int i = 0; i < 6; ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

Pose interpolate(const Pose& a, const Pose& b, double s) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(a.linear()).slerp(s, Eigen::Quaterniond(b.linear())).toRotationMatrix();
  T.translation() = (1 - s) * a.translation() + s * b.translation();
  return T;
}

}  // namespace

bool edgeFree(const CollisionWorld& world, const Waypoint& a, const Waypoint& b, const PlannerConfig& config,
              const CheckOptions& options) {
  constexpr double kRotationStep = 0.05;  // rad, as the driver steps orientation changes
  const robot::ArmConfig& arm = world.arm();
  const double length = (b.T_cell_nozzle.translation() - a.T_cell_nozzle.translation()).norm();
  const double angle = rotationAngle(a.T_cell_nozzle.linear(), b.T_cell_nozzle.linear());
  const int n = std::max({1, static_cast<int>(std::ceil(length / config.collision.edge_step)),
                          static_cast<int>(std::ceil(angle / kRotationStep))});
  robot::Joints q = a.q;
  for (int k = 1; k <= n; ++k) {
    robot::Joints next = b.q;
    if (k < n) {
      const auto ik = robot::inverseNozzle(arm, interpolate(a.T_cell_nozzle, b.T_cell_nozzle, double(k) / n), q);
      if (!ik) return false;
      next = *ik;
    }
    const double turn = maxJointStep(q, next);
    if (turn > config.collision.max_joint_step) return false;
    if (k < n && world.checkArm(next, options)) return false;
    // The driver moves the joints linearly between these IK points: where they turn more than
    // check_resolution (near a singularity), the states in between are checked as well.
    const int between = static_cast<int>(std::ceil(turn / config.transition.check_resolution));
    for (int j = 1; j < between; ++j) {
      robot::Joints mid;
      for (int i = 0; i < 6; ++i) mid[i] = q[i] + (next[i] - q[i]) * j / between;
      if (world.checkArm(mid, options)) return false;
    }
    q = next;
  }
  return true;
}

RefinedPath refinePath(const CollisionWorld& world, const Cloud& tips, Tool tool, double speed, PushMode push,
                       const Point& centre, const robot::Joints& seed, const PlannerConfig& config) {
  const robot::ArmConfig& arm = world.arm();
  const CollisionConfig& cc = config.collision;
  RefinedPath out;
  PathReport& r = out.report;
  std::vector<Waypoint> kept;
  kept.reserve(tips.size());
  robot::Joints prev_q = seed;
  for (std::size_t i = 0; i < tips.size(); ++i) {
    ++r.input;
    Eigen::Vector3d dir(0, 0, 1);
    if (push == PushMode::kOutward) {
      dir = tips[i] - centre;
      dir.z() = 0;
      dir = dir.norm() > 1e-9 ? Eigen::Vector3d(dir.normalized()) : Eigen::Vector3d::UnitX();
    }
    // Try the waypoint where it is, then pushed out step by step.
    Waypoint w;
    w.tool = tool;
    w.speed = speed;
    bool found = false, reachable = true;
    Contact contact;
    const int steps = static_cast<int>(std::floor(cc.max_push / cc.push_step + 1e-9));
    for (int k = 0; k <= steps; ++k) {
      w.T_cell_nozzle = nozzleDown(arm, tips[i] + k * cc.push_step * dir);
      const auto q = robot::inverseNozzle(arm, w.T_cell_nozzle, prev_q);
      if (!q) {
        reachable = k > 0;  // unreachable where it is; a failed push counts as a collision drop
        break;
      }
      contact = world.checkArm(*q);
      if (!contact) {
        w.q = *q;
        found = true;
        if (k > 0) ++r.pushed;
        break;
      }
    }
    if (!found) {
      if (!reachable) {
        ++r.unreachable;
        r.unreachable_indices.push_back(static_cast<int>(i));
      } else {
        ++r.dropped;
        if (r.first_contact.empty()) r.first_contact = contact.what;
      }
      continue;
    }
    kept.push_back(w);
    prev_q = w.q;
    ++r.kept;
  }
  // Can the arm run from each kept waypoint to the next? The edges are independent checks
  // (about half of a new loop's planning time, which is in the depth -> plan latency): the
  // second half of them runs on a second thread.
  std::vector<char> edge_free(kept.size(), 0);
  auto checkEdges = [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = std::max<std::size_t>(begin, 1); j < end; ++j)
      edge_free[j] = edgeFree(world, kept[j - 1], kept[j], config);
  };
  const std::size_t half = kept.size() / 2;
  if (kept.size() >= 8) {
    std::thread second(checkEdges, half, kept.size());
    checkEdges(0, half);
    second.join();
  } else {
    checkEdges(0, kept.size());
  }
  // Where an edge cannot be run, a new piece starts (joined by a transition).
  for (std::size_t j = 0; j < kept.size(); ++j) {
    if (j == 0 || !edge_free[j]) {
      if (j > 0) ++r.cuts;
      out.pieces.emplace_back();
    }
    out.pieces.back().push_back(kept[j]);
  }
  return out;
}

}  // namespace depowder::planner
