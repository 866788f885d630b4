#include "depowder/sim/powder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace depowder::sim {

PowderField::PowderField(double size_x, double size_y, double cell_size) {
  if (!(size_x > 0 && size_y > 0 && cell_size > 0))
    throw std::invalid_argument("PowderField: sizes and cell_size must be positive");
  nx_ = std::max(1, static_cast<int>(std::lround(size_x / cell_size)));
  ny_ = std::max(1, static_cast<int>(std::lround(size_y / cell_size)));
  dx_ = size_x / nx_;
  dy_ = size_y / ny_;
  x0_ = -0.5 * size_x;
  y0_ = -0.5 * size_y;
  const std::size_t n = static_cast<std::size_t>(nx_) * ny_;
  h_.assign(n, 0.0);
  floor_.assign(n, 0.0);
  over_part_.assign(n, 0);
  pass_stamp_.assign(n, -2);
  pass_tool_.assign(n, PassTool::kNone);
  pass_start_.assign(n, 0.0);
  delta_.assign(n, 0.0);
  di0_ = dj0_ = 0;
  di1_ = nx_ - 1;
  dj1_ = ny_ - 1;
}

bool PowderField::cellOf(const Eigen::Vector2d& xy, int& i, int& j) const {
  const double fi = (xy.x() - x0_) / dx_, fj = (xy.y() - y0_) / dy_;
  if (!(fi >= 0 && fj >= 0 && fi < nx_ && fj < ny_)) return false;
  i = static_cast<int>(fi);
  j = static_cast<int>(fj);
  return true;
}

double PowderField::surfaceAt(const Eigen::Vector2d& xy) const {
  const double fi = std::clamp((xy.x() - x0_) / dx_ - 0.5, 0.0, nx_ - 1.0);
  const double fj = std::clamp((xy.y() - y0_) / dy_ - 0.5, 0.0, ny_ - 1.0);
  const int i = std::min(static_cast<int>(fi), std::max(0, nx_ - 2));
  const int j = std::min(static_cast<int>(fj), std::max(0, ny_ - 2));
  const int i1 = std::min(i + 1, nx_ - 1), j1 = std::min(j + 1, ny_ - 1);
  const double a = fi - i, b = fj - j;
  return (1 - a) * (1 - b) * h_[index(i, j)] + a * (1 - b) * h_[index(i1, j)] + (1 - a) * b * h_[index(i, j1)] +
         a * b * h_[index(i1, j1)];
}

double PowderField::setFloor(const std::vector<double>& floor, const std::vector<std::uint8_t>& over_part) {
  if (floor.size() != h_.size() || over_part.size() != h_.size())
    throw std::invalid_argument("PowderField::setFloor: wrong size");
  double raised = 0;
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) {
      const std::size_t c = index(i, j);
      if (floor[c] != floor_[c] || over_part[c] != over_part_[c]) markDirty(i, j);
      floor_[c] = floor[c];
      over_part_[c] = over_part[c];
      if (h_[c] < floor_[c]) {
        raised += floor_[c] - h_[c];
        h_[c] = floor_[c];
      }
    }
  ++version_;
  return raised * cellArea();
}

void PowderField::fill(double level) {
  for (std::size_t c = 0; c < h_.size(); ++c) h_[c] = std::max(level, floor_[c]);
  di0_ = dj0_ = 0;
  di1_ = nx_ - 1;
  dj1_ = ny_ - 1;
  ++version_;
}

void PowderField::setHeight(std::size_t c, double h) {
  h_[c] = std::max(h, floor_[c]);
  markDirty(static_cast<int>(c % nx_), static_cast<int>(c / nx_));
  ++version_;
}

double PowderField::volume() const {
  double v = 0;
  for (std::size_t c = 0; c < h_.size(); ++c) v += h_[c] - floor_[c];
  return v * cellArea();
}

void PowderField::markDirty(int i, int j) {
  if (di0_ > di1_) {
    di0_ = di1_ = i;
    dj0_ = dj1_ = j;
    return;
  }
  di0_ = std::min(di0_, i);
  di1_ = std::max(di1_, i);
  dj0_ = std::min(dj0_, j);
  dj1_ = std::max(dj1_, j);
}

template <class Fn>
void PowderField::forDisc(const Eigen::Vector2d& xy, double r, Fn&& fn) {
  const int i0 = std::max(0, static_cast<int>(std::floor((xy.x() - r - x0_) / dx_)));
  const int i1 = std::min(nx_ - 1, static_cast<int>(std::floor((xy.x() + r - x0_) / dx_)));
  const int j0 = std::max(0, static_cast<int>(std::floor((xy.y() - r - y0_) / dy_)));
  const int j1 = std::min(ny_ - 1, static_cast<int>(std::floor((xy.y() + r - y0_) / dy_)));
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i)
      if ((centre(i, j) - xy).squaredNorm() <= r * r) fn(i, j, index(i, j));
}

double PowderField::passStart(std::size_t c, PassTool tool) {
  if (pass_stamp_[c] != stamp_ - 1 && pass_stamp_[c] != stamp_) pass_tool_[c] = PassTool::kNone;
  if (pass_tool_[c] != tool) {
    pass_tool_[c] = tool;
    pass_start_[c] = h_[c];
  }
  pass_stamp_[c] = stamp_;
  return pass_start_[c];
}

double PowderField::vacuum(const Eigen::Vector3d& tip, const VacuumConfig& config, double dt) {
  const double target = tip.z() - config.standoff;
  double removed = 0;
  forDisc(tip.head<2>(), config.radius, [&](int i, int j, std::size_t c) {
    double limit = std::max(target, passStart(c, PassTool::kVacuum) - config.layer_depth);
    limit = std::max(limit, floor_[c] + (over_part_[c] ? config.residue : 0.0));
    if (h_[c] <= limit) return;
    const double h = std::max(limit, h_[c] - config.sink_rate * dt);
    removed += h_[c] - h;
    h_[c] = h;
    markDirty(i, j);
  });
  if (removed > 0) ++version_;
  return removed * cellArea();
}

double PowderField::airBlast(const Eigen::Vector3d& tip, const AirConfig& config, double dt) {
  if (tip.z() - surfaceAt(tip.head<2>()) > config.reach) return 0;
  double removed = 0;
  forDisc(tip.head<2>(), config.radius, [&](int i, int j, std::size_t c) {
    const double start = passStart(c, PassTool::kAir);
    const double limit = over_part_[c] ? floor_[c] : std::max(floor_[c], start - config.extra_depth);
    if (h_[c] <= limit) return;
    const double h = std::max(limit, h_[c] - config.clear_rate * dt);
    removed += h_[c] - h;
    h_[c] = h;
    markDirty(i, j);
  });
  if (removed > 0) ++version_;
  return removed * cellArea();
}

namespace {
struct Neighbour {
  int di, dj;
};
constexpr Neighbour kNeighbours[8] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, -1}, {1, -1}, {-1, 1}};
}  // namespace

int PowderField::relax(double repose_deg, int max_sweeps, double tolerance) {
  const double t = std::tan(repose_deg * M_PI / 180.0);
  // Largest stable height difference to each neighbour (slope measured between centres).
  double limit[8];
  for (int k = 0; k < 8; ++k) limit[k] = t * std::hypot(kNeighbours[k].di * dx_, kNeighbours[k].dj * dy_);
  int sweeps = 0;
  for (int s = 0; s < max_sweeps && di0_ <= di1_; ++s) {
    // Cells that may give: the changed ones and their neighbours (a neighbour may now stand above them).
    const int i0 = std::max(0, di0_ - 1), i1 = std::min(nx_ - 1, di1_ + 1);
    const int j0 = std::max(0, dj0_ - 1), j1 = std::min(ny_ - 1, dj1_ + 1);
    // Jacobi step: every flow is computed from the same heights, then applied, so the result
    // does not depend on the order of the cells.
    bool moved = false;
    int n0 = nx_, n1 = -1, m0 = ny_, m1 = -1;  // cells changed in this sweep
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const std::size_t c = index(i, j);
        const double movable = h_[c] - floor_[c];
        if (movable <= tolerance) continue;
        double excess[8], sum = 0, largest = 0;
        for (int k = 0; k < 8; ++k) {
          const int a = i + kNeighbours[k].di, b = j + kNeighbours[k].dj;
          excess[k] = 0;
          if (a < 0 || b < 0 || a >= nx_ || b >= ny_) continue;  // the box walls hold the powder
          const double e = h_[c] - h_[index(a, b)] - limit[k];
          if (e > tolerance) {
            excess[k] = e;
            sum += e;
            largest = std::max(largest, e);
          }
        }
        if (sum == 0) continue;
        // Give half the largest excess (the steepest pair would meet exactly at the repose
        // slope on its own), shared in proportion to the excesses; never dig into the floor.
        const double give = std::min(movable, 0.5 * largest);
        delta_[c] -= give;
        for (int k = 0; k < 8; ++k)
          if (excess[k] > 0) delta_[index(i + kNeighbours[k].di, j + kNeighbours[k].dj)] += give * excess[k] / sum;
        moved = true;
        n0 = std::min(n0, i - 1);
        n1 = std::max(n1, i + 1);
        m0 = std::min(m0, j - 1);
        m1 = std::max(m1, j + 1);
      }
    if (!moved) {
      di0_ = 1;
      di1_ = 0;  // at rest
      break;
    }
    n0 = std::max(0, n0);
    n1 = std::min(nx_ - 1, n1);
    m0 = std::max(0, m0);
    m1 = std::min(ny_ - 1, m1);
    for (int j = m0; j <= m1; ++j)
      for (int i = n0; i <= n1; ++i) {
        const std::size_t c = index(i, j);
        h_[c] += delta_[c];
        delta_[c] = 0;
      }
    di0_ = n0;
    di1_ = n1;
    dj0_ = m0;
    dj1_ = m1;
    ++sweeps;
    ++version_;
  }
  return sweeps;
}

double PowderField::maxSlopeExcess(double repose_deg) const {
  const double t = std::tan(repose_deg * M_PI / 180.0);
  double worst = 0;
  for (int j = 0; j < ny_; ++j)
    for (int i = 0; i < nx_; ++i) {
      const std::size_t c = index(i, j);
      if (h_[c] - floor_[c] <= 0) continue;
      for (const auto& n : kNeighbours) {
        const int a = i + n.di, b = j + n.dj;
        if (a < 0 || b < 0 || a >= nx_ || b >= ny_) continue;
        // Only the powder that could flow counts: at most the cell's own layer.
        const double e = std::min(h_[c] - floor_[c], h_[c] - h_[index(a, b)] - t * std::hypot(n.di * dx_, n.dj * dy_));
        worst = std::max(worst, e);
      }
    }
  return worst;
}

}  // namespace depowder::sim
