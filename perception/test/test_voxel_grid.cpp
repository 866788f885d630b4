// Voxel grid: counts and centroids on lattices, agreement with depowder::voxelDownsample,
// the dense and hashed tables, and isolated-voxel removal.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "depowder/perception/depth.hpp"
#include "depowder/perception/voxel_grid.hpp"
#include "depowder/point_grid.hpp"

using namespace depowder;
using namespace depowder::perception;

namespace {

const Eigen::AlignedBox3d kRegion = cropBox({0.4, 0.3, 0.2}, 0.01);

bool lexLess(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

Cloud sorted(Cloud c) {
  std::sort(c.begin(), c.end(), lexLess);
  return c;
}

Cloud randomCloud(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-0.2, 0.2), y(-0.15, 0.15), z(0.0, 0.2);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i) c.emplace_back(x(rng), y(rng), z(rng));
  return c;
}

}  // namespace

TEST(VoxelGrid, LatticeCountsAndCentroids) {
  // A 1 mm lattice (cell centres at 0.5 mm + i mm) filling [0, 10 mm)^3: 1000 points, which a
  // 5 mm grid aligned to the origin splits into 8 voxels of 125 points each.
  Cloud lattice;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      for (int k = 0; k < 10; ++k) lattice.emplace_back(0.0005 + 0.001 * i, 0.0005 + 0.001 * j, 0.0005 + 0.001 * k);
  VoxelGrid grid(kRegion, 0.005);
  EXPECT_TRUE(grid.dense());
  grid.add(lattice);
  const VoxelGrid::Result r = grid.extract();
  ASSERT_EQ(r.points.size(), 8u);
  EXPECT_EQ(r.voxels, 8u);
  // Each voxel's centroid is the middle of its 5 mm cube: 2.5 mm or 7.5 mm on each axis.
  for (const Eigen::Vector3d& p : r.points)
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(std::min(std::abs(p[a] - 0.0025), std::abs(p[a] - 0.0075)), 0, 1e-12) << p.transpose();
  // The grid is empty again afterwards.
  EXPECT_TRUE(grid.extract().points.empty());
}

TEST(VoxelGrid, IgnoresPointsOutsideTheRegionAndNaN) {
  VoxelGrid grid(kRegion, 0.005);
  grid.add({{0, 0, 0.05}, {0.5, 0, 0.05}, {0, 0, -0.2}, {std::nan(""), 0, 0}, {0.001, 0.001, 0.051}});
  const VoxelGrid::Result r = grid.extract();
  EXPECT_EQ(r.points.size(), 1u);
  EXPECT_EQ(r.outside, 3u);
  EXPECT_NEAR((r.points[0] - Eigen::Vector3d(0.0005, 0.0005, 0.0505)).norm(), 0, 1e-12);
}

TEST(VoxelGrid, MatchesCommonVoxelDownsampleDenseAndHashed) {
  const Cloud a = randomCloud(20000, 1), b = randomCloud(20000, 2);
  Cloud both = a;
  both.insert(both.end(), b.begin(), b.end());
  for (double leaf : {0.002, 0.005, 0.008}) {
    const Cloud expected = sorted(voxelDownsample(both, leaf));
    VoxelGrid dense(kRegion, leaf), hashed(kRegion, leaf, /*max_dense_cells=*/0);
    ASSERT_TRUE(dense.dense());
    ASSERT_FALSE(hashed.dense());
    dense.add(a);
    dense.add(b);
    hashed.add(b);  // other order: same voxels
    hashed.add(a);
    for (VoxelGrid* g : {&dense, &hashed}) {
      const Cloud got = sorted(g->extract().points);
      ASSERT_EQ(got.size(), expected.size()) << "leaf " << leaf;
      double worst = 0;
      for (std::size_t i = 0; i < got.size(); ++i) worst = std::max(worst, (got[i] - expected[i]).norm());
      EXPECT_LT(worst, 1e-12) << "leaf " << leaf;
    }
  }
}

TEST(VoxelGrid, IsolatedVoxelRemoval) {
  // A 10 cm x 10 cm plane sampled every 1 mm at z = 52.5 mm (samples off the 5 mm voxel
  // boundaries: 20 x 20 voxels), plus 50 points scattered above it, at least 1.75 cm from
  // the plane and 2 cm from each other: more than a voxel diagonal, so none has a neighbour.
  Cloud cloud;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) cloud.emplace_back(-0.0495 + 0.001 * i, -0.0495 + 0.001 * j, 0.0525);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-0.05, 0.05), z(0.07, 0.19);
  Cloud stray;
  while (stray.size() < 50) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    bool far = true;
    for (const auto& q : stray) far = far && (p - q).norm() > 0.02;
    if (far) stray.push_back(p);
  }
  cloud.insert(cloud.end(), stray.begin(), stray.end());
  VoxelGrid grid(kRegion, 0.005);
  grid.add(cloud);
  const std::size_t all = grid.extract(0).points.size();
  EXPECT_EQ(all, 20u * 20u + 50u);
  grid.add(cloud);
  const VoxelGrid::Result r = grid.extract(3);
  // Every stray voxel goes; a plane voxel has at least 3 occupied neighbours (corners: 3).
  EXPECT_EQ(r.outliers, 50u);
  EXPECT_EQ(r.points.size(), 400u);
  for (const auto& p : r.points) EXPECT_NEAR(p.z(), 0.0525, 1e-12);
  // Demanding 4 neighbours also removes the plane's 4 corner voxels.
  grid.add(cloud);
  EXPECT_EQ(grid.extract(4).points.size(), 396u);
  // The hashed table (no fixed neighbour offsets) decides the same.
  VoxelGrid hashed(kRegion, 0.005, 0);
  hashed.add(cloud);
  const VoxelGrid::Result h = hashed.extract(3);
  EXPECT_EQ(h.outliers, 50u);
  EXPECT_EQ(sorted(h.points), sorted(r.points));
}
