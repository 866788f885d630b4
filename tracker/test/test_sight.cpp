// SightImages: CAD points judged against the cameras' lines of sight, on a scan of a flat floor
// whose answer is known point by point.
#include <gtest/gtest.h>

#include <vector>

#include "depowder/tracker/sight.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

// A floor z = 0 sampled every 5 mm over 20 x 20 cm (the camera proxy's voxels), seen from the
// default cell's two cameras.
struct Floor {
  Cloud scan;
  std::vector<Point> eyes{{0.0, -0.35, 0.75}, {0.0, 0.35, 0.75}};
  Eigen::AlignedBox3d region{Eigen::Vector3d(-0.05, -0.05, -0.05), Eigen::Vector3d(0.05, 0.05, 0.05)};
  Floor() {
    for (double x = -0.1; x <= 0.1; x += 0.005)
      for (double y = -0.1; y <= 0.1; y += 0.005) scan.emplace_back(x, y, 0.0);
  }
};

// A 5 x 5 patch of upward-facing points at height z.
void patch(double z, const Eigen::Vector3d& normal, Cloud& points, Cloud& normals) {
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j) {
      points.emplace_back(0.01 * i, 0.01 * j, z);
      normals.push_back(normal);
    }
}

TEST(SightImages, JudgesEachPointAgainstTheFloor) {
  const Floor f;
  const SightImages images(f.scan, f.eyes, f.region);
  Cloud points, normals;
  patch(0.002, Eigen::Vector3d::UnitZ(), points, normals);  // on the floor: seen
  patch(0.03, Eigen::Vector3d::UnitZ(), points, normals);   // 3 cm above it: the cameras saw through it
  patch(-0.03, Eigen::Vector3d::UnitZ(), points, normals);  // 3 cm below it: hidden by the floor
  patch(0.03, -Eigen::Vector3d::UnitZ(), points, normals);  // facing down: no camera judges it
  std::vector<unsigned char> verdict;
  const SightCheck c = images.check(points, normals, 0.008, &verdict);
  EXPECT_EQ(c.seen, 25);
  EXPECT_EQ(c.in_front, 25);
  EXPECT_EQ(c.hidden, 25);
  EXPECT_EQ(c.unknown, 25);
  ASSERT_EQ(verdict.size(), 100u);
  for (int k = 0; k < 100; ++k) {
    const SightCheck::Verdict want[] = {SightCheck::kSeen, SightCheck::kInFront, SightCheck::kHidden,
                                        SightCheck::kUnknown};
    EXPECT_EQ(verdict[k], want[k / 25]) << "point " << k;
  }
}

// Where the scan has no point along a line of sight (a hole: the nozzle filtered out, or a
// camera that saw nothing there) nothing is judged: missing data is no evidence.
TEST(SightImages, AHoleInTheScanIsNoEvidence) {
  Floor f;
  Cloud holed;
  for (const Point& p : f.scan)
    if (p.head<2>().norm() > 0.06) holed.push_back(p);
  const SightImages images(holed, f.eyes, f.region);
  Cloud points, normals;
  patch(0.03, Eigen::Vector3d::UnitZ(), points, normals);
  const SightCheck c = images.check(points, normals, 0.008);
  EXPECT_EQ(c.in_front, 0);
  EXPECT_EQ(c.unknown, 25);
}

TEST(SightImages, NoCamerasJudgeNothing) {
  const Floor f;
  const SightImages images(f.scan, {}, f.region);
  Cloud points, normals;
  patch(0.03, Eigen::Vector3d::UnitZ(), points, normals);
  EXPECT_EQ(images.check(points, normals, 0.008).unknown, 25);
}

}  // namespace
