#include "depowder/sim/noise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace depowder::sim {
namespace {

// Standard normal quantiles at (i + 0.5) / 65536, rescaled to unit variance (the midpoint
// rule trims the tails at +-4.3 sigma, which would leave the variance 0.1 % short).
const std::array<float, 65536>& normalTable() {
  static const std::array<float, 65536> table = [] {
    std::array<double, 65536> q{};
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double p = (static_cast<double>(i) + 0.5) / 65536.0;
      double x = 0;  // Newton on Phi(x) = p, from 0; Phi is log-concave so this converges
      for (int it = 0; it < 60; ++it) {
        const double f = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
        const double d = std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI);
        const double step = f / d;
        x -= std::max(-1.0, std::min(1.0, step));
        if (std::abs(step) < 1e-13) break;
      }
      q[i] = x;
    }
    double var = 0;
    for (double x : q) var += x * x;
    const double scale = 1.0 / std::sqrt(var / q.size());
    std::array<float, 65536> t{};
    for (std::size_t i = 0; i < q.size(); ++i) t[i] = static_cast<float>(q[i] * scale);
    return t;
  }();
  return table;
}

double uniform01(std::mt19937& rng) { return (rng() + 0.5) * (1.0 / 4294967296.0); }

}  // namespace

double grazingDropoutProbability(const DepthNoise& n, double incidence_deg) {
  if (incidence_deg <= n.grazing_dropout_deg) return 0;
  if (n.grazing_dropout_deg >= 90) return 0;
  return std::min(1.0, (incidence_deg - n.grazing_dropout_deg) / (90.0 - n.grazing_dropout_deg));
}

void makeDepthImage(const DepthRasterizer& raster, const CameraModel& camera, double depth_unit, std::mt19937* rng,
                    DepthImage& out) {
  const int W = raster.width(), H = raster.height();
  out.camera = camera.name;
  out.width = W;
  out.height = H;
  out.fx = camera.fx;
  out.fy = camera.fy;
  out.cx = camera.cx;
  out.cy = camera.cy;
  out.min_range = camera.min_range;
  out.max_range = camera.max_range;
  out.depth_unit = depth_unit;
  out.T_cell_camera = camera.T_cell_camera;
  out.depth.assign(static_cast<std::size_t>(W) * H, 0);

  const DepthNoise& noise = camera.noise;
  const float* table = normalTable().data();
  const std::uint32_t dropout_threshold =
      static_cast<std::uint32_t>(std::lround(std::min(1.0, std::max(0.0, noise.dropout_prob)) * 65536.0));
  const double cos_grazing = std::cos(noise.grazing_dropout_deg * M_PI / 180.0);
  const double inv_unit = 1.0 / depth_unit;
  const std::vector<float>& inv = raster.inverseDepth();

  for (int v = 0; v < H; ++v) {
    const double yn = (v - camera.cy) / camera.fy;
    for (int u = 0; u < W; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * W + u;
      const std::uint32_t draw = rng ? (*rng)() : 0;  // one per pixel, hit or not: streams stay aligned
      if (!(inv[i] > 0)) continue;
      double z = 1.0 / inv[i];
      const double xn = (u - camera.cx) / camera.fx;
      const double k = std::sqrt(xn * xn + yn * yn + 1.0);  // range / z along this pixel's ray
      if (rng) {
        if ((draw & 0xFFFFu) < dropout_threshold) continue;
        // Grazing incidence: the normal against the unit ray.
        const Eigen::Vector3f n = raster.normal(u, v);
        const double c = std::abs(n.x() * xn + n.y() * yn + n.z()) / k;
        if (c < cos_grazing) {
          const double deg = std::acos(std::min(1.0, c)) * 180.0 / M_PI;
          if (uniform01(*rng) < grazingDropoutProbability(noise, deg)) continue;
        }
        // Flying pixel: the 4-neighbour with the largest jump decides the edge.
        double jump = 0;
        const auto consider = [&](std::size_t j) {
          if (inv[j] > 0) {
            const double d = 1.0 / inv[j] - z;
            if (std::abs(d) > std::abs(jump)) jump = d;
          }
        };
        if (u > 0) consider(i - 1);
        if (u + 1 < W) consider(i + 1);
        if (v > 0) consider(i - W);
        if (v + 1 < H) consider(i + W);
        if (std::abs(jump) > noise.flying_edge && uniform01(*rng) < noise.flying_pixel_prob)
          z += uniform01(*rng) * jump;
        const double range = z * k;
        z = (range + rangeSigma(noise, range) * table[draw >> 16]) / k;
      }
      const double range = z * k;
      if (!(range >= camera.min_range && range <= camera.max_range)) continue;
      const double counts = std::round(z * inv_unit);
      if (counts >= 1 && counts <= 65535) out.depth[i] = static_cast<std::uint16_t>(counts);
    }
  }
}

}  // namespace depowder::sim
