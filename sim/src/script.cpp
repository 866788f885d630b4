#include "depowder/sim/script.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

namespace depowder::sim {

Pose nozzlePose(const Eigen::Vector3d& tip, const Eigen::Vector3d& spray) {
  const Eigen::Vector3d z = spray.normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z);
  if (x.norm() < 1e-6) x = z.cross(Eigen::Vector3d::UnitX());
  x.normalize();
  Pose T = Pose::Identity();
  T.linear() << x, z.cross(x), z;
  T.translation() = tip;
  return T;
}

double ScriptSegment::duration() const {
  if (kind == Kind::kOrbit) return std::abs(orbit.period) * orbit.revolutions;
  return waypoints.empty() ? 0.0 : waypoints.back().t;
}

NozzleScript::NozzleScript(std::vector<ScriptSegment> segments, bool loop)
    : segments_(std::move(segments)), loop_(loop) {
  for (const auto& s : segments_) {
    if (s.kind == ScriptSegment::Kind::kWaypoints) {
      if (s.waypoints.empty()) throw std::invalid_argument("NozzleScript: a waypoint segment needs waypoints");
      for (std::size_t k = 1; k < s.waypoints.size(); ++k)
        if (!(s.waypoints[k].t > s.waypoints[k - 1].t))
          throw std::invalid_argument("NozzleScript: waypoint times must increase");
    } else if (!(s.orbit.period != 0 && s.orbit.revolutions > 0)) {
      throw std::invalid_argument("NozzleScript: an orbit needs a non-zero period and revolutions > 0");
    }
    duration_ += s.duration();
  }
}

namespace {

ArmState orbitAt(const Orbit& o, double t) {
  const double turns = t / o.period;  // negative period: clockwise
  const double a = o.start_deg * M_PI / 180.0 + 2 * M_PI * turns;
  const Eigen::Vector2d xy = o.centre + Eigen::Vector2d(o.radii.x() * std::cos(a), o.radii.y() * std::sin(a));
  const double z = std::max(o.min_height, o.height - o.descend_per_rev * std::abs(turns));
  Eigen::Vector3d inward(o.centre.x() - xy.x(), o.centre.y() - xy.y(), 0);
  if (inward.norm() > 1e-9) inward.normalize();
  const double tilt = o.tilt_deg * M_PI / 180.0;
  const Eigen::Vector3d spray = std::cos(tilt) * Eigen::Vector3d(0, 0, -1) + std::sin(tilt) * inward;
  ArmState s;
  s.nozzle_present = true;
  s.T_cell_nozzle = nozzlePose({xy.x(), xy.y(), z}, spray);
  s.tool = o.tool;
  return s;
}

ArmState waypointsAt(const std::vector<Waypoint>& w, double t) {
  ArmState s;
  s.nozzle_present = true;
  if (t <= w.front().t) {
    s.T_cell_nozzle = w.front().T_cell_nozzle;
    s.tool = w.front().tool;
    return s;
  }
  for (std::size_t k = 1; k < w.size(); ++k) {
    if (t > w[k].t) continue;
    const double f = (t - w[k - 1].t) / (w[k].t - w[k - 1].t);
    const Pose& A = w[k - 1].T_cell_nozzle;
    const Pose& B = w[k].T_cell_nozzle;
    s.T_cell_nozzle = Pose::Identity();
    s.T_cell_nozzle.translation() = (1 - f) * A.translation() + f * B.translation();
    s.T_cell_nozzle.linear() =
        Eigen::Quaterniond(A.linear()).slerp(f, Eigen::Quaterniond(B.linear())).normalized().toRotationMatrix();
    s.tool = w[k].tool;
    return s;
  }
  s.T_cell_nozzle = w.back().T_cell_nozzle;
  s.tool = w.back().tool;
  return s;
}

}  // namespace

ArmState NozzleScript::at(double t) const {
  if (segments_.empty()) return {};
  if (loop_ && duration_ > 0) t = std::fmod(std::max(0.0, t), duration_);
  for (std::size_t k = 0; k < segments_.size(); ++k) {
    const ScriptSegment& s = segments_[k];
    const bool last = k + 1 == segments_.size();
    if (t <= s.duration() || last) {
      const double local = std::min(t, s.duration());
      return s.kind == ScriptSegment::Kind::kOrbit ? orbitAt(s.orbit, local) : waypointsAt(s.waypoints, local);
    }
    t -= s.duration();
  }
  return {};
}

}  // namespace depowder::sim
