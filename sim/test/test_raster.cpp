// Noise-free depth images against analytic ray casts: a plane (seen obliquely, extending behind
// the camera, so near-plane clipping is exercised), the empty build box, and a cube in the box.
#include <gtest/gtest.h>

#include "analytic.hpp"
#include "depowder/parts.hpp"
#include "depowder/sim/noise.hpp"
#include "depowder/sim/raster.hpp"

using namespace depowder;
using namespace depowder::sim;
using namespace depowder::sim::test;

namespace {

constexpr double kDepthUnit = 0.00025;
// Noise-free tolerance: half a depth count of quantisation plus float round-off.
constexpr double kTolerance = 0.5 * kDepthUnit + 2e-5;

struct Comparison {
  int both = 0;       ///< pixels valid in both
  int bad_depth = 0;  ///< of those, beyond kTolerance
  int only_one = 0;   ///< valid in one image only
  double worst = 0;   ///< m
};

Comparison compare(const DepthImage& img, const CameraModel& cam, const std::vector<Rect>& rects) {
  Comparison c;
  const Eigen::Vector3d o = cam.T_cell_camera.translation();
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u) {
      double z = castRects(o, pixelRay(cam, u, v), rects);
      const double range = z * rangePerDepth(cam, u, v);
      if (!(range >= cam.min_range && range <= cam.max_range)) z = 0;
      const double got = img.metres(u, v);
      if ((z > 0) != (got > 0)) {
        ++c.only_one;
        continue;
      }
      if (z == 0) continue;
      ++c.both;
      c.worst = std::max(c.worst, std::abs(got - z));
      if (std::abs(got - z) > kTolerance) ++c.bad_depth;
    }
  return c;
}

CameraModel camera(int w, int h, const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  return CameraModel::fromFov("T", w, h, 70, 55, lookAt(position, target));
}

}  // namespace

TEST(Raster, ObliquePlaneMatchesRayCast) {
  const CameraModel cam = camera(640, 480, {0, 0, 0.5}, {1.0, 0.3, 0});
  Mesh plane;  // 20 m square at z = 0, reaching behind the camera (clipped at the near plane)
  plane.vertices = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  plane.triangles = {{0, 1, 2}, {0, 2, 3}};
  DepthRasterizer r;
  r.begin(cam);
  r.drawMesh(plane.vertices, plane.triangles, Pose::Identity(), Culling::kBackFaces);
  DepthImage img;
  makeDepthImage(r, cam, kDepthUnit, nullptr, img);
  const Comparison c = compare(img, cam, {{{0, 0, 0}, 2, {10, 10, 0}}});
  EXPECT_GT(c.both, 640 * 480 / 2);
  EXPECT_EQ(c.bad_depth, 0) << "worst " << c.worst;
  EXPECT_LE(c.only_one, 640 * 480 / 1000) << "pixels valid in one image only";
}

TEST(Raster, BackFacesCulledOnlyWhenAsked) {
  const CameraModel cam = camera(64, 48, {0, 0, 1}, {0, 0, 0});
  Mesh down;  // a square facing -z, seen from above: its back
  down.vertices = {{-1, -1, 0}, {-1, 1, 0}, {1, 1, 0}, {1, -1, 0}};
  down.triangles = {{0, 1, 2}, {0, 2, 3}};
  DepthRasterizer r;
  r.begin(cam);
  r.drawMesh(down.vertices, down.triangles, Pose::Identity(), Culling::kBackFaces);
  EXPECT_EQ(r.depth(32, 24), 0.0f);
  r.drawMesh(down.vertices, down.triangles, Pose::Identity(), Culling::kNone);
  EXPECT_NEAR(r.depth(32, 24), 1.0f, 1e-6);
}

TEST(Raster, EmptyBoxAndCubeMatchRayCast) {
  SimConfig config;
  config.powder.level = 0;  // no powder: everything is bare, so the floor and the cube show
  config.scene.table_size = 0;
  const BoxGeometry box;
  const Eigen::AlignedBox3d cube_box(Eigen::Vector3d(0.02, -0.01, 0.0), Eigen::Vector3d(0.08, 0.05, 0.06));
  const Pose T_cell_cube(Eigen::Translation3d(cube_box.center()));
  const std::vector<CameraModel> cams{camera(640, 480, {0.25, -0.45, 0.5}, {0, 0, 0.03}),
                                      camera(320, 240, {-0.3, 0.35, 0.45}, {0, 0, 0.0})};

  World empty(config, box, {}, cams);
  World with_cube(config, box, {{"cube", parts::cube(), T_cell_cube, 1000}}, cams);
  std::vector<Rect> rects = boxRects(box), rects_cube = boxRects(box);
  addBox(rects_cube, cube_box);
  for (std::size_t i = 0; i < cams.size(); ++i) {
    for (const auto& [world, scene] : {std::pair{&empty, &rects}, std::pair{&with_cube, &rects_cube}}) {
      const DepthImage img = world->render(i, nullptr);
      const Comparison c = compare(img, cams[i], *scene);
      const int pixels = img.width * img.height;
      EXPECT_GT(c.both, pixels / 5);
      // Silhouette pixels may fall either way of an edge; nothing else may differ.
      EXPECT_LE(c.bad_depth, pixels / 1000) << "camera " << i << " worst " << c.worst;
      EXPECT_LE(c.only_one, pixels / 1000) << "camera " << i;
    }
  }
}

TEST(Raster, PowderSurfaceIsTheHeightField) {
  // A flat powder surface at 7 cm renders exactly as the plane z = 0.07 inside the box.
  SimConfig config;
  config.powder.level = 0.07;
  config.scene.table_size = 0;
  const BoxGeometry box;
  const CameraModel cam = camera(320, 240, {0.0, -0.35, 0.55}, {0, 0, 0.05});
  World world(config, box, {}, {cam});
  std::vector<Rect> rects = boxRects(box);
  rects[0].c.z() = 0.07;  // the floor rectangle becomes the powder surface
  const DepthImage img = world.render(0, nullptr);
  const Comparison c = compare(img, cam, rects);
  EXPECT_LE(c.bad_depth, img.width * img.height / 1000) << "worst " << c.worst;
  EXPECT_LE(c.only_one, img.width * img.height / 1000);
}
