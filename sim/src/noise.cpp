#include "depowder/sim/noise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace depowder::sim {
namespace {

// Standard normal quantiles at (i + 0.5) / 8192, rescaled to unit variance (the midpoint rule
// trims the tails at +-3.8 sigma, which would leave the variance 0.4 % short). 32 kB: the table
// stays in the L1 cache, which matters at one lookup per pixel.
constexpr int kTableBits = 13;
const std::array<float, 1 << kTableBits>& normalTable() {
  static const std::array<float, 1 << kTableBits> table = [] {
    std::array<double, 1 << kTableBits> q{};
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double p = (static_cast<double>(i) + 0.5) / q.size();
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
    std::array<float, 1 << kTableBits> t{};
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
  out.T_cell_camera = camera.framePose();
  out.depth.assign(static_cast<std::size_t>(W) * H, 0);

  const DepthNoise& noise = camera.noise;
  const float* table = normalTable().data();
  const std::uint32_t dropout_threshold =
      static_cast<std::uint32_t>(std::lround(std::min(1.0, std::max(0.0, noise.dropout_prob)) * 65536.0));
  const double cos_grazing = std::cos(noise.grazing_dropout_deg * M_PI / 180.0);
  const double inv_unit = 1.0 / depth_unit;
  const float edge = static_cast<float>(noise.flying_edge);

  // Depth (0: nothing) once per pixel.
  const std::vector<float>& inv = raster.inverseDepth();
  const std::vector<float>& ks = raster.rangePerDepth();
  std::vector<float> zbuf(inv.size());
  for (std::size_t i = 0; i < inv.size(); ++i) zbuf[i] = inv[i] > 0 ? 1.0f / inv[i] : 0.0f;
  std::vector<float> xs(W);
  for (int u = 0; u < W; ++u) xs[u] = static_cast<float>((u - camera.cx) / camera.fx);
  const float min_range = static_cast<float>(camera.min_range), max_range = static_cast<float>(camera.max_range);
  const float sigma_base = static_cast<float>(noise.sigma_base), sigma_per_m = static_cast<float>(noise.sigma_per_m);

  for (int v = 0; v < H; ++v) {
    const float yn = static_cast<float>((v - camera.cy) / camera.fy);
    for (int u = 0; u < W; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * W + u;
      const std::uint32_t draw = rng ? (*rng)() : 0;  // one per pixel, hit or not: streams stay aligned
      const float z0 = zbuf[i];
      if (z0 == 0) continue;
      const float k = ks[i];  // range / z along this pixel's ray
      float z = z0;
      if (rng) {
        if ((draw & 0xFFFFu) < dropout_threshold) continue;
        // Grazing incidence: the normal against the unit ray (x / z, y / z, 1) / k.
        const Eigen::Vector3f n = raster.normal(u, v);
        const float c = std::abs(n.x() * xs[u] + n.y() * yn + n.z());
        if (c < cos_grazing * k) {
          const double deg = std::acos(std::min(1.0, c / static_cast<double>(k))) * 180.0 / M_PI;
          if (uniform01(*rng) < grazingDropoutProbability(noise, deg)) continue;
        }
        // Flying pixel: the 4-neighbour with the largest jump decides the edge.
        float jump = 0;
        const auto consider = [&](std::size_t j) {
          if (zbuf[j] != 0 && std::abs(zbuf[j] - z0) > std::abs(jump)) jump = zbuf[j] - z0;
        };
        if (u > 0) consider(i - 1);
        if (u + 1 < W) consider(i + 1);
        if (v > 0) consider(i - W);
        if (v + 1 < H) consider(i + W);
        if (std::abs(jump) > edge && uniform01(*rng) < noise.flying_pixel_prob)
          z += static_cast<float>(uniform01(*rng)) * jump;
        // Range noise along the ray, as depth: dz = dr / k.
        const float sigma = sigma_base + sigma_per_m * (z * k);
        z += sigma * table[draw >> (32 - kTableBits)] / k;
      }
      const float range = z * k;
      if (!(range >= min_range && range <= max_range)) continue;
      const double counts = z * inv_unit + 0.5;  // positive: truncation rounds to nearest
      if (counts >= 1 && counts < 65536) out.depth[i] = static_cast<std::uint16_t>(counts);
    }
  }
}

}  // namespace depowder::sim
