#include "depowder/sim/push.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "depowder/sim/world.hpp"

namespace depowder::sim {
namespace {

// Möller-Trumbore: t along d where o + t d meets triangle abc, or +inf.
double rayTriangle(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& a,
                   const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-18) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d s = o - a;
  const double u = s.dot(p) / det;
  if (u < 0 || u > 1) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d q = s.cross(e1);
  const double v = d.dot(q) / det;
  if (v < 0 || u + v > 1) return std::numeric_limits<double>::infinity();
  const double t = e2.dot(q) / det;
  return t > 0 ? t : std::numeric_limits<double>::infinity();
}

Eigen::AlignedBox3d posedBounds(const World& world, std::size_t part) {
  Eigen::AlignedBox3d b;
  const Pose& T = world.part(part).T_cell_part;
  for (const auto& v : world.part(part).mesh.vertices) b.extend(T * v);
  return b;
}

}  // namespace

const char* toString(PushPhase phase) {
  switch (phase) {
    case PushPhase::kDescend:
      return "descend";
    case PushPhase::kPush:
      return "push";
    case PushPhase::kSettle:
      return "settle";
    case PushPhase::kRetract:
      return "retract";
    case PushPhase::kDone:
      return "done";
  }
  return "?";
}

const char* toString(PushOutcome outcome) {
  switch (outcome) {
    case PushOutcome::kRunning:
      return "running";
    case PushOutcome::kReachedWall:
      return "reached the wall";
    case PushOutcome::kNozzleAtWall:
      return "nozzle at the wall";
    case PushOutcome::kStalled:
      return "stalled";
  }
  return "?";
}

PushScript::PushScript(const World& world, const PushSpec& spec) : world_(world), spec_(spec) {
  dir_ = Eigen::Vector3d(spec.direction.x(), spec.direction.y(), 0);
  if (dir_.norm() < 1e-9) throw std::invalid_argument("PushScript: the push direction has no horizontal part");
  dir_.normalize();
  side_ = Eigen::Vector3d(-dir_.y(), dir_.x(), 0);
  const Pose& T = world.part(spec.part).T_cell_part;
  const Eigen::Vector3d contact = T * spec.contact_part;
  const double radius = world.config().nozzle.radius;
  tip_ = contact - dir_ * (radius + spec.gap);
  push_z_ = std::max(contact.z() - spec.tip_below, 0.003);
  // The nozzle comes down beside the part, not onto it: where the contact face is oblique to the
  // push (or an edge or overhang is nearer than the contact point), step back along the push line
  // until no part of the surface above the tip's pushing height is within radius + gap of its axis.
  const double clear = radius + spec.gap;
  const Cloud surface = sampleSurface(world.part(spec.part).mesh, 0.002).points;
  for (int back = 0; back < 200; ++back) {  // at most 20 cm
    double nearest = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& q : surface) {
      const Eigen::Vector3d p = T * q;
      if (p.z() >= push_z_) nearest = std::min(nearest, (p - tip_).head<2>().norm());
    }
    if (nearest >= clear - 1e-4) break;
    tip_ -= dir_ * 0.001;
  }
  const double top = std::max(posedBounds(world, spec.part).max().z(), world.powder().surfaceAt(tip_.head<2>()));
  high_z_ = top + spec.clearance;
  tip_.z() = high_z_;
  progress_origin_ = T.translation();
}

bool PushScript::partAtWall() const {
  const Eigen::AlignedBox3d b = posedBounds(world_, spec_.part);
  const Eigen::Vector3d half = 0.5 * world_.box().size;
  for (int a = 0; a < 2; ++a) {
    if (dir_[a] > 0.3 && b.max()[a] >= half[a] - spec_.wall_gap) return true;
    if (dir_[a] < -0.3 && b.min()[a] <= -half[a] + spec_.wall_gap) return true;
  }
  return false;
}

bool PushScript::nozzleAtWall() const {
  const Eigen::Vector3d half = 0.5 * world_.box().size;
  const double r = world_.config().nozzle.radius + spec_.wall_gap;
  for (int a = 0; a < 2; ++a) {
    if (dir_[a] > 0.1 && tip_[a] + r >= half[a]) return true;
    if (dir_[a] < -0.1 && tip_[a] - r <= -half[a]) return true;
  }
  return false;
}

ArmState PushScript::update(double t) {
  const double dt = std::max(0.0, t - last_t_);
  last_t_ = t;
  const Pose& T = world_.part(spec_.part).T_cell_part;
  switch (phase_) {
    case PushPhase::kDescend:
      tip_.z() -= spec_.approach_speed * dt;
      if (tip_.z() <= push_z_) {
        tip_.z() = push_z_;
        phase_ = PushPhase::kPush;
        progress_origin_ = T.translation();
        progress_time_ = t;
      }
      break;
    case PushPhase::kPush: {
      if ((T.translation() - progress_origin_).norm() > 0.001) {
        progress_origin_ = T.translation();
        progress_time_ = t;
      }
      if (partAtWall())
        outcome_ = PushOutcome::kReachedWall;
      else if (nozzleAtWall())
        outcome_ = PushOutcome::kNozzleAtWall;
      else if (t - progress_time_ > spec_.stall_time)
        outcome_ = PushOutcome::kStalled;
      if (outcome_ != PushOutcome::kRunning) {
        phase_ = PushPhase::kSettle;
        phase_start_ = t;
        break;
      }
      tip_ += dir_ * (spec_.speed * dt);
      pushed_ += spec_.speed * dt;
      if (spec_.steer) {  // toward the part's centre line, at most half the push speed sideways
        const double err = side_.dot(posedBounds(world_, spec_.part).center() - tip_);
        const double most = 0.5 * spec_.speed * dt;
        tip_ += side_ * std::clamp(err, -most, most);
      }
      break;
    }
    case PushPhase::kSettle:
      if (t - phase_start_ >= spec_.settle) phase_ = PushPhase::kRetract;
      break;
    case PushPhase::kRetract:
      tip_.z() += spec_.approach_speed * dt;
      if (tip_.z() >= high_z_) {
        tip_.z() = high_z_;
        phase_ = PushPhase::kDone;
      }
      break;
    case PushPhase::kDone:
      break;
  }
  ArmState a;
  a.nozzle_present = true;
  a.T_cell_nozzle = nozzlePose(tip_, Eigen::Vector3d(0, 0, -1));
  a.tool = Tool::kOff;
  return a;
}

PushSpec pushFrom(const World& world, std::size_t part, double azimuth_deg, double height, double offset) {
  const Eigen::AlignedBox3d b = posedBounds(world, part);
  const double az = azimuth_deg * M_PI / 180.0;
  // `side`: left of the push direction (-out turned +90 deg).
  const Eigen::Vector3d out(std::cos(az), std::sin(az), 0), side(std::sin(az), -std::cos(az), 0);
  Eigen::Vector3d origin = b.center() + out * b.diagonal().norm() + side * offset;
  origin.z() = b.min().z() + std::clamp(height, 0.0, 1.0) * (b.max().z() - b.min().z());
  const Eigen::Vector3d d = -out;
  const Pose& T = world.part(part).T_cell_part;
  const Mesh& mesh = world.part(part).mesh;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& tri : mesh.triangles)
    best = std::min(
        best, rayTriangle(origin, d, T * mesh.vertices[tri[0]], T * mesh.vertices[tri[1]], T * mesh.vertices[tri[2]]));
  if (!std::isfinite(best))
    throw std::invalid_argument("pushFrom: the ray from " + std::to_string(azimuth_deg) + " deg, height " +
                                std::to_string(height) + ", offset " + std::to_string(offset) + " m misses part '" +
                                world.part(part).name + "'");
  PushSpec spec;
  spec.part = part;
  spec.contact_part = T.inverse() * (origin + best * d);
  spec.direction = d;
  return spec;
}

}  // namespace depowder::sim
