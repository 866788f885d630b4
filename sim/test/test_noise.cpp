// The noise model against its configuration: range sigma (and its growth with range), random
// and grazing drop-out rates, flying pixels at depth edges; seeded streams are reproducible.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "analytic.hpp"
#include "depowder/sim/noise.hpp"
#include "depowder/sim/raster.hpp"

using namespace depowder;
using namespace depowder::sim;
using namespace depowder::sim::test;

namespace {

constexpr double kUnit = 0.00025;

DepthNoise quiet() {  // everything off; each test turns on what it measures
  DepthNoise n;
  n.sigma_base = n.sigma_per_m = n.flying_pixel_prob = n.dropout_prob = 0;
  n.grazing_dropout_deg = 90;
  return n;
}

Mesh square(double half, double z) {
  Mesh m;
  m.vertices = {{-half, -half, z}, {half, -half, z}, {half, half, z}, {-half, half, z}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

struct Frames {
  DepthImage clean;
  std::vector<DepthImage> noisy;
};

// `count` noisy frames of the meshes from one seeded stream, and the noise-free frame.
Frames renderFrames(const CameraModel& cam, const std::vector<Mesh>& meshes, int count, std::uint32_t seed = 42) {
  DepthRasterizer r;
  r.begin(cam);
  for (const auto& m : meshes) r.drawMesh(m.vertices, m.triangles, Pose::Identity(), Culling::kNone);
  Frames f;
  makeDepthImage(r, cam, kUnit, nullptr, f.clean);
  std::mt19937 rng(seed);
  f.noisy.resize(count);
  for (auto& img : f.noisy) makeDepthImage(r, cam, kUnit, &rng, img);
  return f;
}

// A camera 0.5 m above an endless floor looking at (1, 0, 0): ranges from 0.5 m to the horizon,
// incidence from 25 to 90 deg.
CameraModel obliqueCamera(const DepthNoise& noise) {
  CameraModel cam = CameraModel::fromFov("T", 640, 480, 70, 55, lookAt({0, 0, 0.5}, {1.0, 0, 0}));
  cam.noise = noise;
  return cam;
}

double incidenceDeg(const CameraModel& cam, int u, int v) {
  const Eigen::Vector3d d = pixelRay(cam, u, v).normalized();
  return std::acos(std::abs(d.z())) * 180 / M_PI;
}

}  // namespace

TEST(Noise, RangeSigmaMatchesTheModelAtEveryRange) {
  DepthNoise noise = quiet();
  noise.sigma_base = 0.0010;
  noise.sigma_per_m = 0.0025;
  const CameraModel cam = obliqueCamera(noise);
  const Frames f = renderFrames(cam, {square(20, 0)}, 1);
  // Normalised range residuals, overall and in range bins.
  struct Bin {
    double lo, hi, sum2 = 0, model2 = 0;
    int n = 0;
  };
  std::vector<Bin> bins{{0.5, 0.7}, {0.9, 1.2}, {1.5, 2.5}, {3.0, 6.0}};
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const double z = f.clean.metres(u, v), zn = f.noisy[0].metres(u, v);
      if (z == 0 || zn == 0) continue;
      const double k = rangePerDepth(cam, u, v), range = z * k, e = (zn - z) * k;
      const double s = 0.0010 + 0.0025 * range;  // the configured model, written out
      sum += e / s;
      sum2 += (e / s) * (e / s);
      ++n;
      for (auto& b : bins)
        if (range >= b.lo && range < b.hi) {
          b.sum2 += e * e;
          b.model2 += s * s;
          ++b.n;
        }
    }
  ASSERT_GT(n, 100000);
  // Standard errors: mean 1/sqrt(n) ~ 0.002, sigma 1/sqrt(2n) ~ 0.0015; quantisation adds < 0.1 %.
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.01);
  for (const auto& b : bins) {
    ASSERT_GT(b.n, 5000) << b.lo;
    EXPECT_NEAR(std::sqrt(b.sum2 / b.model2), 1.0, 0.03) << "range bin [" << b.lo << ", " << b.hi << ") m";
  }
}

TEST(Noise, RandomDropoutRate) {
  DepthNoise noise = quiet();
  noise.dropout_prob = 0.05;
  const CameraModel cam = obliqueCamera(noise);
  const Frames f = renderFrames(cam, {square(20, 0)}, 1);
  int valid = 0, dropped = 0;
  for (std::size_t i = 0; i < f.clean.depth.size(); ++i) {
    if (f.clean.depth[i] == 0) continue;
    ++valid;
    dropped += f.noisy[0].depth[i] == 0;
  }
  ASSERT_GT(valid, 100000);
  EXPECT_NEAR(double(dropped) / valid, 0.05, 0.003);  // 5 standard errors
}

TEST(Noise, GrazingDropoutRampsFromThresholdTo90Degrees) {
  DepthNoise noise = quiet();
  noise.grazing_dropout_deg = 70;
  const CameraModel cam = obliqueCamera(noise);
  const Frames f = renderFrames(cam, {square(20, 0)}, 1);
  struct Bin {
    double lo, hi, expected = 0;
    int n = 0, dropped = 0;
  };
  std::vector<Bin> bins{{40, 68}, {72, 76}, {80, 84}, {86, 89}};
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      if (f.clean.metres(u, v) == 0) continue;
      const double deg = incidenceDeg(cam, u, v);
      for (auto& b : bins)
        if (deg >= b.lo && deg < b.hi) {
          ++b.n;
          b.dropped += f.noisy[0].metres(u, v) == 0;
          b.expected += std::clamp((deg - 70.0) / 20.0, 0.0, 1.0);  // linear ramp 70 -> 90 deg
        }
    }
  EXPECT_EQ(bins[0].dropped, 0);
  EXPECT_GT(bins[0].n, 10000);
  for (std::size_t k = 1; k < bins.size(); ++k) {
    const auto& b = bins[k];
    ASSERT_GT(b.n, 2000) << b.lo;
    const double p = b.expected / b.n;
    EXPECT_NEAR(double(b.dropped) / b.n, p, 4 * std::sqrt(p * (1 - p) / b.n) + 0.005) << "bin " << b.lo;
  }
}

TEST(Noise, FlyingPixelsOnlyAtDepthEdgesWithTheConfiguredRate) {
  DepthNoise noise = quiet();
  noise.flying_pixel_prob = 0.3;
  noise.flying_edge = 0.01;
  CameraModel cam = CameraModel::fromFov("T", 640, 480, 70, 55, lookAt({0.01, 0.02, 0.6}, {0.01, 0.02, 0}));
  cam.noise = noise;
  // A 10 cm square 8 cm above the floor: its outline is a depth edge.
  const Frames f = renderFrames(cam, {square(1, 0), square(0.05, 0.08)}, 10);
  int edge = 0, moved = 0, off_edge_moved = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u) {
      const double z = f.clean.metres(u, v);
      double jump = 0;
      for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int a = u + du, b = v + dv;
        if (a < 0 || b < 0 || a >= cam.width || b >= cam.height || f.clean.metres(a, b) == 0) continue;
        const double d = f.clean.metres(a, b) - z;
        if (std::abs(d) > std::abs(jump)) jump = d;
      }
      for (const DepthImage& img : f.noisy) {
        const double zn = img.metres(u, v);
        if (std::abs(jump) > noise.flying_edge) {
          ++edge;
          if (std::abs(zn - z) > 1.5 * kUnit) {
            ++moved;
            // A mixed depth lies between the pixel's own surface and its neighbour's.
            EXPECT_LE(std::abs(zn - z), std::abs(jump) + kUnit);
            EXPECT_GT((zn - z) * jump, 0);
          }
        } else if (zn != z) {
          ++off_edge_moved;
        }
      }
    }
  ASSERT_GT(edge, 5000);
  EXPECT_EQ(off_edge_moved, 0);
  // Moved = chosen (0.3) and mixed by more than 1.5 counts (jump 8 cm: all but ~0.5 %).
  EXPECT_NEAR(double(moved) / edge, 0.3 * (1 - 1.5 * kUnit / 0.08), 0.02);
}

TEST(Noise, NoiseFreeDepthIsQuantisedTruth) {
  const CameraModel cam = CameraModel::fromFov("T", 64, 48, 70, 55, lookAt({0, 0, 0.61237}, {0, 0, 0}));
  const Frames f = renderFrames(cam, {square(5, 0)}, 0);
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u)
      EXPECT_EQ(f.clean.depth[v * cam.width + u], static_cast<std::uint16_t>(std::lround(0.61237 / kUnit)));
}

TEST(Noise, SeededStreamsAreReproducible) {
  const CameraModel cam = obliqueCamera(DepthNoise{});  // the default model, everything on
  const Frames a = renderFrames(cam, {square(20, 0), square(0.05, 0.08)}, 2, 7);
  const Frames b = renderFrames(cam, {square(20, 0), square(0.05, 0.08)}, 2, 7);
  const Frames c = renderFrames(cam, {square(20, 0), square(0.05, 0.08)}, 2, 8);
  EXPECT_EQ(a.noisy[0].depth, b.noisy[0].depth);
  EXPECT_EQ(a.noisy[1].depth, b.noisy[1].depth);
  EXPECT_NE(a.noisy[0].depth, a.noisy[1].depth);
  EXPECT_NE(a.noisy[0].depth, c.noisy[0].depth);
}
