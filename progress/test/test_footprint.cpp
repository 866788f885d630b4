// The 2-D silhouette: distances, hole filling and the ordered iso-contour.
#include <gtest/gtest.h>

#include <cmath>

#include "depowder/progress/footprint.hpp"
#include "scenes.hpp"

namespace depowder::progress {
namespace {

TEST(Footprint, ContourOfASquareIsItsOffset) {
  const double half = 0.04;
  const Cloud cad = test::boxSurface({-half, -half, 0}, {half, half, 0.05}, 0.002);
  const Footprint fp(cad, 0.002, 0.01, 0.03);
  for (double level : {0.0125, 0.02}) {
    const Polyline2 loop = fp.outerContour(level, 0.005);
    // Perimeter of the offset square: 8 half + 2 pi level.
    const double perimeter = 8 * half + 2 * M_PI * level;
    EXPECT_NEAR(static_cast<double>(loop.size()), perimeter / 0.005, 1.0);
    double area = 0;
    for (std::size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++) {
      EXPECT_NEAR(test::distanceToSquare(loop[i].x(), loop[i].y(), half), level, 0.0015) << loop[i].transpose();
      area += loop[j].x() * loop[i].y() - loop[i].x() * loop[j].y();
    }
    EXPECT_GT(area, 0);
  }
}

TEST(Footprint, ExactDistanceAndInsideOutside) {
  const double half = 0.04;
  const Cloud cad = test::boxSurface({-half, -half, 0}, {half, half, 0.05}, 0.002);
  const Footprint fp(cad, 0.002, 0.01, 0.03);
  EXPECT_NEAR(fp.distance({half + 0.012, 0.0}, 0.02), 0.012, 1e-9);  // samples on the x = half face
  EXPECT_TRUE(std::isinf(fp.distance({half + 0.025, 0.0}, 0.02)));
  EXPECT_TRUE(fp.within({half + 0.012, 0.0}, 0.0121));
  EXPECT_FALSE(fp.within({half + 0.012, 0.0}, 0.0119));
  EXPECT_FALSE(fp.within({1.0, 1.0}, 0.02));
  EXPECT_FALSE(fp.outside({0, 0}));
  EXPECT_FALSE(fp.outside({half + 0.008, 0}));  // within close_radius
  EXPECT_TRUE(fp.outside({half + 0.013, 0}));
  EXPECT_FALSE(fp.outside({1.0, 1.0}));  // off the raster
}

TEST(Footprint, HolesAreFilledButTheOutsideIsNot) {
  // A ring of radius 5 cm (samples every 1 mm): its 10 cm wide inside is a hole, filled.
  Cloud ring;
  for (int k = 0; k < 314; ++k) ring.emplace_back(0.05 * std::cos(k * 0.02), 0.05 * std::sin(k * 0.02), 0.0);
  const Footprint fp(ring, 0.002, 0.01, 0.02);
  EXPECT_FALSE(fp.outside({0, 0}));
  EXPECT_FALSE(fp.outside({0.03, 0}));
  EXPECT_DOUBLE_EQ(fp.rasterDistance({0.0, 0.0}), -1.0);
  EXPECT_TRUE(fp.outside({0.065, 0}));
  const Polyline2 loop = fp.outerContour(0.0125, 0.005);
  ASSERT_FALSE(loop.empty());
  for (const Point2& p : loop) EXPECT_NEAR(p.norm(), 0.0625, 0.0015);  // the outer loop only
}

TEST(Footprint, EmptyInputGivesAnEmptyFootprint) {
  const Footprint fp({}, 0.002, 0.01, 0.02);
  EXPECT_TRUE(fp.empty());
  EXPECT_FALSE(fp.outside({0, 0}));
  EXPECT_TRUE(fp.outerContour(0.01, 0.005).empty());
}

}  // namespace
}  // namespace depowder::progress
