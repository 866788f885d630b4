// ScanIndex::nearest is exact: the same answer as brute force, for queries on and off the
// cloud, near its bounds and outside them, with radii smaller and larger than a cell.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "depowder/tracker/scan_index.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

TEST(ScanIndex, MatchesBruteForce) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  std::normal_distribution<double> n(0.0, 0.002);
  Cloud cloud;
  for (int i = 0; i < 3000; ++i) {
    // Points on two planes and a sphere, as a scan has them on surfaces.
    const double x = u(rng), y = u(rng);
    if (i % 3 == 0) cloud.emplace_back(x, y, n(rng));
    if (i % 3 == 1) cloud.emplace_back(x, n(rng) + 0.05, y);
    if (i % 3 == 2) cloud.push_back(Point(x, y, u(rng)).normalized() * 0.04);
  }
  cloud.emplace_back(std::numeric_limits<double>::quiet_NaN(), 0, 0);  // skipped
  for (const double cell : {0.005, 0.01, 0.03}) {
    const ScanIndex index(cloud, cell);
    EXPECT_EQ(index.size(), cloud.size() - 1);
    for (int k = 0; k < 2000; ++k) {
      const Point q(1.3 * u(rng), 1.3 * u(rng), 1.3 * u(rng));
      const double radius = (k % 4 + 1) * 0.004;
      int best = -1;
      double best_d2 = radius * radius;
      for (std::size_t i = 0; i + 1 < cloud.size(); ++i) {
        const double d2 = (cloud[i] - q).squaredNorm();
        if (d2 <= best_d2) best_d2 = d2, best = static_cast<int>(i);
      }
      const ScanIndex::Hit hit = index.nearest(q, radius);
      ASSERT_EQ(hit.found(), best >= 0) << "cell " << cell << " query " << k;
      if (best >= 0) {
        EXPECT_DOUBLE_EQ(hit.distance2, best_d2);
        EXPECT_DOUBLE_EQ((index.point(hit.index) - q).squaredNorm(), best_d2);
      }
    }
  }
}

TEST(ScanIndex, EmptyAndInvalidQueries) {
  const ScanIndex empty(Cloud{}, 0.01);
  EXPECT_FALSE(empty.nearest(Point::Zero(), 1.0).found());
  const ScanIndex one(Cloud{Point(0.1, 0.2, 0.3)}, 0.01);
  EXPECT_TRUE(one.nearest(Point(0.1, 0.2, 0.305), 0.01).found());
  EXPECT_FALSE(one.nearest(Point(0.1, 0.2, 0.32), 0.01).found());
  EXPECT_FALSE(one.nearest(Point(std::numeric_limits<double>::quiet_NaN(), 0, 0), 1.0).found());
  EXPECT_FALSE(one.nearest(Point(0.1, 0.2, 0.3), 0.0).found());
}

}  // namespace
