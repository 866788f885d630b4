#include "depowder/sim/powder_support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace depowder::sim {
namespace {

constexpr double kNoPowder = -std::numeric_limits<double>::infinity();

// Two unit tangents completing n.
void tangents(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2) {
  t1 = (std::abs(n.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX()).cross(n).normalized();
  t2 = n.cross(t1);
}

}  // namespace

std::vector<SurfaceSample> outerSurfaceSamples(const Mesh& mesh, const FilledSolid& filled, double spacing,
                                               std::uint32_t seed) {
  const SurfaceSamples all = sampleSurface(mesh, spacing, seed);
  const double area = surfaceArea(mesh) / static_cast<double>(all.points.size());
  std::vector<SurfaceSample> out;
  for (std::size_t i = 0; i < all.points.size(); ++i) {
    if (filled.contains(all.points[i] + 0.001 * all.normals[i])) continue;
    out.push_back({all.points[i], all.normals[i], area});
  }
  return out;
}

void powderLevels(const std::vector<SurfaceSample>& samples, const Pose& T_cell_part, const PowderField& powder,
                  const std::function<bool(std::size_t)>& covered, double repose_deg, std::vector<double>& levels) {
  const double slope = std::tan(repose_deg * M_PI / 180.0);
  levels.assign(samples.size(), kNoPowder);
  const double cell = std::max(powder.dx(), powder.dy());
  const int max_steps = std::max(powder.nx(), powder.ny());
  static const Eigen::Vector2d kDirections[8] = {{1, 0},
                                                 {-1, 0},
                                                 {0, 1},
                                                 {0, -1},
                                                 {M_SQRT1_2, M_SQRT1_2},
                                                 {-M_SQRT1_2, -M_SQRT1_2},
                                                 {M_SQRT1_2, -M_SQRT1_2},
                                                 {-M_SQRT1_2, M_SQRT1_2}};
  // The level of the first cell off the footprint along d from xy (false: the box wall comes first).
  auto exitLevel = [&](const Eigen::Vector2d& xy, const Eigen::Vector2d& d, int max_s, int& steps, double& h) {
    for (int s = 1; s <= max_s; ++s) {
      int i, j;
      if (!powder.cellOf(xy + d * (s * cell), i, j)) return false;
      const std::size_t c = powder.index(i, j);
      if (covered(c)) continue;
      steps = s;
      h = powder.height(c);
      return true;
    }
    return false;
  };
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const Eigen::Vector3d p = T_cell_part * samples[k].p;
    const Eigen::Vector3d n = T_cell_part.linear() * samples[k].n;
    const Eigen::Vector2d nxy = n.head<2>();
    const double len = nxy.norm();
    int i, j, steps;
    double h;
    if (!powder.cellOf(p.head<2>(), i, j)) continue;
    const std::size_t own = powder.index(i, j);
    if (n.z() > 0 && (p.z() >= powder.floor(own) - cell || len < 0.5)) {
      levels[k] = powder.height(own);  // a top face: the powder on it
    } else if (len >= 0.5) {           // a wall: the powder beside it, off the footprint
      if (exitLevel(p.head<2>(), nxy / len, max_steps, steps, h)) levels[k] = h;
    } else {
      // A bottom face rests on the hidden powder under the part. That powder stands only as high as
      // the angle of repose allows from the nearest ways out of the footprint (the easiest one
      // governs): above it, it has run out and the face hangs free. Its bearing comes from the
      // surcharge where the nearest way out leads (ties averaged), at least level with the face.
      double sum = 0, reach = std::numeric_limits<double>::infinity();
      int nearest = max_steps, count = 0;
      for (const Eigen::Vector2d& d : kDirections) {
        if (!exitLevel(p.head<2>(), d, max_steps, steps, h)) continue;
        reach = std::min(reach, h + slope * steps * cell);
        if (steps > nearest) continue;
        if (steps < nearest) {
          nearest = steps;
          sum = 0;
          count = 0;
        }
        sum += h;
        ++count;
      }
      if (count == 0)
        levels[k] = powder.height(own);
      else if (p.z() <= reach)
        levels[k] = std::max(sum / count, p.z());
    }
  }
}

PowderSupport::PowderSupport(const PowderForceConfig& config, std::vector<SurfaceSample> samples,
                             const Pose& T_body_part, double mass, const Eigen::Vector3d& inertia, double gravity)
    : config_(config),
      gravity_(gravity),
      inv_mass_(1.0 / mass),
      inv_inertia_(inertia.cwiseInverse()),
      samples_(std::move(samples)) {
  levels_.assign(samples_.size(), kNoPowder);
  lambda_.assign(samples_.size(), Eigen::Vector3d::Zero());
  // Everything about a sample that the body's motion does not change, in the body frame.
  auto effectiveMass = [&](const Eigen::Vector3d& rj) {
    return 1.0 / (inv_mass_ + rj.dot(inv_inertia_.cwiseProduct(rj)));
  };
  for (const SurfaceSample& s : samples_) {
    BodySample b;
    b.r = T_body_part * s.p;
    b.n = T_body_part.linear() * s.n;
    tangents(b.n, b.t1, b.t2);
    const Eigen::Vector3d rn = b.r.cross(b.n), rt1 = b.r.cross(b.t1), rt2 = b.r.cross(b.t2);
    b.an = inv_inertia_.cwiseProduct(rn);
    b.at1 = inv_inertia_.cwiseProduct(rt1);
    b.at2 = inv_inertia_.cwiseProduct(rt2);
    b.mn = effectiveMass(rn);
    b.mt1 = effectiveMass(rt1);
    b.mt2 = effectiveMass(rt2);
    body_.push_back(b);
  }
}

void PowderSupport::reset() { std::fill(lambda_.begin(), lambda_.end(), Eigen::Vector3d::Zero()); }

PowderSupport::Result PowderSupport::solve(const Pose& T_cell_body, const Eigen::Vector3d& v_cell,
                                           const Eigen::Vector3d& w_cell, const Eigen::Vector3d& dv_free, double h) {
  Result out;
  // The whole solve runs in the body frame (inertia diagonal, samples fixed).
  const Eigen::Matrix3d& R = T_cell_body.linear();
  const Eigen::Vector3d up_b = R.row(2).transpose();  // cell +z in the body frame
  const double z0 = T_cell_body.translation().z();
  const Eigen::Vector3d v0 = R.transpose() * v_cell, w0 = R.transpose() * w_cell;
  Eigen::Vector3d v = v0 + R.transpose() * dv_free, w = w0;
  auto apply = [&](const Eigen::Vector3d& r, const Eigen::Vector3d& J) {
    v += J * inv_mass_;
    w += inv_inertia_.cwiseProduct(r.cross(J));
  };

  // 1. Buried samples: at-rest pressure, impulse bounds, warm start.
  rows_.clear();
  const double rho_g = config_.density * gravity_;
  for (std::size_t k = 0; k < body_.size(); ++k) {
    const BodySample& b = body_[k];
    const double nz = up_b.dot(b.n);
    double depth = levels_[k] - (z0 + up_b.dot(b.r));
    if (nz < -0.5) depth += config_.footing_depth;
    if (!(depth > 0)) {
      lambda_[k].setZero();
      continue;
    }
    ++out.buried;
    Row row;
    row.k = k;
    const double sigma_a = rho_g * depth * samples_[k].area;  // N
    // At-rest pressure: K sigma on the horizontal part of the normal, the powder's weight on upward faces.
    const double up = std::max(0.0, nz);
    const double K = config_.lateral_pressure;
    apply(b.r, (-sigma_a * h) * (K * b.n + (up - K * nz) * up_b));
    // Resistance bounds, growing with speed (drag). Shear: mu times the at-rest pressure normal to the
    // face (K sigma on a wall, sigma under powder); a footing's also grows with the load it bears
    // (coupling walls and tops to their bearing impulse would let the solver wedge the part in place).
    const double drag = 1 + (v0 + w0.cross(b.r)).norm() / config_.drag_speed;
    const double normal_rest = K * std::max(0.0, 1 - nz * nz) + up * up;
    const double down = std::max(0.0, -nz);
    const double N = config_.passive_factor + (config_.bearing_factor - config_.passive_factor) * down * down;
    row.cap_n = N * sigma_a * drag * h;
    row.mu = nz < -0.5 ? config_.shear_factor : 0.0;  // Coulomb (mu > 1 with the drag would self-lock)
    row.cap_t0 = config_.shear_factor * drag * normal_rest * sigma_a * h;
    Eigen::Vector3d& lam = lambda_[k];  // (normal, t1, t2) from the last substep, within today's bounds
    lam.x() = std::clamp(lam.x(), -row.cap_n, 0.0);
    const double lt = std::sqrt(lam.y() * lam.y() + lam.z() * lam.z());
    const double cap_t = std::max(0.0, row.cap_t0 - row.mu * lam.x());
    if (lt > cap_t) lam.tail<2>() *= cap_t / lt;  // lt > 0 here
    apply(b.r, lam.x() * b.n + lam.y() * b.t1 + lam.z() * b.t2);
    rows_.push_back(row);
  }

  // 2. Projected Gauss-Seidel: each sample's velocity into the powder -> 0, within its bounds.
  for (int it = 0; it < config_.iterations; ++it) {
    double change = 0;
    for (const Row& row : rows_) {
      const BodySample& b = body_[row.k];
      Eigen::Vector3d& lam = lambda_[row.k];
      // Normal: the powder only pushes (lambda_n <= 0 along the outward normal).
      const double ln = std::clamp(lam.x() - b.mn * (v + w.cross(b.r)).dot(b.n), -row.cap_n, 0.0);
      const double dn = ln - lam.x();
      lam.x() = ln;
      v += (dn * inv_mass_) * b.n;
      w += dn * b.an;
      // Tangential: a Coulomb-like disc.
      const Eigen::Vector3d u = v + w.cross(b.r);
      double l1 = lam.y() - b.mt1 * u.dot(b.t1), l2 = lam.z() - b.mt2 * u.dot(b.t2);
      const double lt = std::sqrt(l1 * l1 + l2 * l2), cap_t = std::max(0.0, row.cap_t0 - row.mu * ln);
      if (lt > cap_t) {
        const double s = cap_t / lt;
        l1 *= s;
        l2 *= s;
      }
      const double d1 = l1 - lam.y(), d2 = l2 - lam.z();
      lam.y() = l1;
      lam.z() = l2;
      v += inv_mass_ * (d1 * b.t1 + d2 * b.t2);
      w += d1 * b.at1 + d2 * b.at2;
      change = std::max({change, std::abs(dn), std::abs(d1), std::abs(d2)});
    }
    if (change * inv_mass_ < 1e-9) break;  // m/s: converged
  }
  out.v = R * v - dv_free;
  out.w = R * w;
  return out;
}

}  // namespace depowder::sim
