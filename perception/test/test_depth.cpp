// Deprojection, extrinsics and crop against hand-computed and analytic ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "depowder/perception/depth.hpp"
#include "synthetic.hpp"

using namespace depowder;
using namespace depowder::perception;

namespace {

const Eigen::AlignedBox3d kEverywhere(Eigen::Vector3d::Constant(-100), Eigen::Vector3d::Constant(100));

// 4 x 2 pixels, fx 100, fy 200, principal point (1.5, 0.5), 2 m above the cell origin looking
// straight down: camera x = cell x, camera y = -cell y, camera z = -cell z.
PinholeCamera handCamera() {
  PinholeCamera c;
  c.name = "HAND";
  c.width = 4;
  c.height = 2;
  c.fx = 100;
  c.fy = 200;
  c.cx = 1.5;
  c.cy = 0.5;
  c.min_range = 0.25;
  c.max_range = 9.0;
  c.T_cell_camera = Pose::Identity();
  c.T_cell_camera.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  c.T_cell_camera.translation() = Eigen::Vector3d(0, 0, 2);
  return c;
}

DepthImage handImage() {
  DepthImage im;
  im.utime = 1000;
  im.frame = 7;
  im.width = 4;
  im.height = 2;
  im.depth_unit = 0.00025;
  im.depth.assign(8, 0);
  im.depth[0] = 6000;          // (u 0, v 0): z = 1.5 m
  im.depth[1 * 4 + 3] = 4000;  // (u 3, v 1): z = 1.0 m
  return im;
}

}  // namespace

TEST(Deproject, HandComputedPinholeExample) {
  const CameraCloud out = deproject(handImage(), handCamera(), kEverywhere);
  ASSERT_TRUE(out.error.ok()) << out.error.message;
  ASSERT_EQ(out.points.size(), 2u);
  // (0, 0) at 1.5 m: camera ((0 - 1.5) / 100 * 1.5, (0 - 0.5) / 200 * 1.5, 1.5) = (-0.0225, -0.00375, 1.5)
  //   -> cell (-0.0225, 0.00375, 2 - 1.5).
  EXPECT_NEAR((out.points[0] - Eigen::Vector3d(-0.0225, 0.00375, 0.5)).norm(), 0, 1e-12);
  // (3, 1) at 1.0 m: camera (0.015, 0.0025, 1.0) -> cell (0.015, -0.0025, 1.0).
  EXPECT_NEAR((out.points[1] - Eigen::Vector3d(0.015, -0.0025, 1.0)).norm(), 0, 1e-12);
  EXPECT_EQ(out.counts.inputs, 8u);
  EXPECT_EQ(out.counts.no_return, 6u);
  EXPECT_EQ(out.counts.kept, 2u);
}

TEST(Deproject, RangeLimitsApplyToTheDistanceFromTheCamera) {
  PinholeCamera cam = handCamera();
  cam.min_range = 1.2;  // drops the 1.0 m return
  CameraCloud out = deproject(handImage(), cam, kEverywhere);
  ASSERT_TRUE(out.error.ok());
  ASSERT_EQ(out.points.size(), 1u);
  EXPECT_NEAR(out.points[0].z(), 0.5, 1e-12);
  EXPECT_EQ(out.counts.out_of_range, 1u);
  // The (3, 1) return has z = 1.0 but lies |(0.015, 0.0025, 1)| = 1.0001156 m from the camera:
  // a 1.0001 m limit drops it (it is a range limit, not a depth limit), 1.0002 m keeps it.
  cam.min_range = 0.25;
  cam.max_range = 1.0001;
  out = deproject(handImage(), cam, kEverywhere);
  EXPECT_EQ(out.error.status, FrameStatus::kNoValidReturns);  // both returns are out of range
  EXPECT_EQ(out.points.size(), 0u);
  EXPECT_EQ(out.counts.out_of_range, 2u);
  cam.max_range = 1.0002;
  out = deproject(handImage(), cam, kEverywhere);
  ASSERT_EQ(out.points.size(), 1u);
  EXPECT_NEAR(out.points[0].z(), 1.0, 1e-12);
}

TEST(Deproject, CropKeepsOnlyTheBoxPlusMargin) {
  const Eigen::AlignedBox3d crop = cropBox({0.4, 0.3, 0.2}, 0.01);
  EXPECT_TRUE(crop.min().isApprox(Eigen::Vector3d(-0.21, -0.16, -0.01)));
  EXPECT_TRUE(crop.max().isApprox(Eigen::Vector3d(0.21, 0.16, 0.21)));
  // The hand example's points are at z 0.5 and 1.0: outside this crop. Lower the camera so
  // that the 1.5 m return lands at z = 0.1 (inside) and the 1.0 m one at z = 0.6 (outside).
  PinholeCamera cam = handCamera();
  cam.T_cell_camera.translation().z() = 1.6;
  const CameraCloud out = deproject(handImage(), cam, crop);
  ASSERT_TRUE(out.error.ok());
  ASSERT_EQ(out.points.size(), 1u);
  EXPECT_NEAR((out.points[0] - Eigen::Vector3d(-0.0225, 0.00375, 0.1)).norm(), 0, 1e-12);
  EXPECT_EQ(out.counts.outside_crop, 1u);
}

TEST(Deproject, CorruptFramesGiveClearErrors) {
  // Buffer size disagrees with the header.
  DepthImage im = handImage();
  im.depth.pop_back();
  CameraCloud out = deproject(im, handCamera(), kEverywhere);
  EXPECT_EQ(out.error.status, FrameStatus::kSizeMismatch);
  EXPECT_NE(out.error.message.find("carries 7 depth pixels but its header says 4x2 = 8"), std::string::npos)
      << out.error.message;
  EXPECT_NE(out.error.message.find("HAND"), std::string::npos);
  EXPECT_TRUE(out.points.empty());
  // Header disagrees with the camera.
  im = handImage();
  PinholeCamera cam = handCamera();
  cam.width = 8;
  EXPECT_EQ(deproject(im, cam, kEverywhere).error.status, FrameStatus::kSizeMismatch);
  // NaN intrinsics, zero depth unit, a non-rigid pose.
  cam = handCamera();
  cam.fx = std::nan("");
  EXPECT_EQ(deproject(im, cam, kEverywhere).error.status, FrameStatus::kBadHeader);
  // Finite but absurd: rays of inf or NaN (the Deprojector once searched 65535 counts a pixel).
  for (const auto& [fx, cx] : {std::pair{1e-310, 1.5}, std::pair{0.5, 1e308}, std::pair{1e-3, 1.5}}) {
    cam = handCamera();
    cam.fx = fx;
    cam.cx = cx;
    out = deproject(im, cam, kEverywhere);
    EXPECT_EQ(out.error.status, FrameStatus::kBadHeader) << fx << " " << cx;
    EXPECT_NE(out.error.message.find("89.9 deg off the optical axis"), std::string::npos) << out.error.message;
  }
  im.depth_unit = 0;
  EXPECT_EQ(deproject(im, handCamera(), kEverywhere).error.status, FrameStatus::kBadHeader);
  cam = handCamera();
  cam.T_cell_camera.linear() *= 2.0;
  EXPECT_EQ(deproject(handImage(), cam, kEverywhere).error.status, FrameStatus::kBadHeader);
  // No return at all: the depth-image form of an all-NaN frame.
  im = handImage();
  std::fill(im.depth.begin(), im.depth.end(), 0);
  out = deproject(im, handCamera(), kEverywhere);
  EXPECT_EQ(out.error.status, FrameStatus::kNoValidReturns);
  EXPECT_NE(out.error.message.find("no valid return (8 of 8 pixels empty"), std::string::npos) << out.error.message;
}

TEST(Deproject, AllNaNScanIsRejectedAndNaNPointsAreDropped) {
  PinholeCamera cam = handCamera();
  const double nan = std::nan("");
  Cloud scan(100, Eigen::Vector3d(nan, nan, nan));
  CameraCloud out = cameraPointsToCell(scan, cam, kEverywhere);
  EXPECT_EQ(out.error.status, FrameStatus::kNoValidReturns);
  EXPECT_NE(out.error.message.find("100 of 100 NaN"), std::string::npos) << out.error.message;
  scan[3] = Eigen::Vector3d(0.1, 0.2, 1.0);
  out = cameraPointsToCell(scan, cam, kEverywhere);
  ASSERT_TRUE(out.error.ok());
  ASSERT_EQ(out.points.size(), 1u);
  EXPECT_NEAR((out.points[0] - Eigen::Vector3d(0.1, -0.2, 1.0)).norm(), 0, 1e-12);
  EXPECT_EQ(out.counts.no_return, 99u);
}

// A cell point P seen by two cameras with arbitrary poses lands at P from both. Each
// camera's principal point is shifted by the sub-pixel part of P's projection, so that a
// pixel centre looks exactly at P; the scene is rendered by ray casting (no noise).
TEST(Deproject, ExtrinsicsComposeTwoCamerasAgreeWithinOneMillimetre) {
  using namespace synthetic;
  const Scene scene = boxScene({0.4, 0.3, 0.2}, 0.08, {Sphere{{0.03, -0.02, 0.09}, 0.04}});
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const Eigen::AlignedBox3d crop = cropBox({0.4, 0.3, 0.2}, 0.01);
  int checked = 0;
  for (int attempt = 0; attempt < 200 && checked < 12; ++attempt) {
    // P: on the powder surface, or on the upper half of the sphere.
    const Eigen::Vector3d P = attempt % 2 == 0
                                  ? Eigen::Vector3d(0.12 * uni(rng), 0.08 * uni(rng), 0.08)
                                  : Eigen::Vector3d(0.03, -0.02, 0.09) +
                                        0.04 * Eigen::Vector3d(0.4 * uni(rng), 0.4 * uni(rng), 1.0).normalized();
    ASSERT_LT(scene.distance(P), 1e-12);
    // Cameras on either side, at random heights and offsets, aimed near (not at) P.
    PinholeCamera cams[2];
    bool visible = true;
    for (int k = 0; k < 2; ++k) {
      const double side = k == 0 ? -1.0 : 1.0;
      const Eigen::Vector3d position(0.15 * uni(rng), side * (0.35 + 0.1 * uni(rng)), 0.5 + 0.1 * uni(rng));
      const Eigen::Vector3d target = P + Eigen::Vector3d(0.03 * uni(rng), 0.03 * uni(rng), 0);
      cams[k] = makeCamera(k == 0 ? "A" : "B", 160, 120, lookAt(position, target));
      // Skip a P hidden from this camera (inside or behind the sphere).
      const Eigen::Vector3d ray = P - position;
      visible = visible && std::abs(scene.raycast(position, ray) - 1.0) < 1e-9;
    }
    if (!visible) continue;
    Eigen::Vector3d seen[2];
    for (int k = 0; k < 2; ++k) {
      PinholeCamera& cam = cams[k];
      const Eigen::Vector3d q = cam.T_cell_camera.inverse() * P;
      const double u = cam.fx * q.x() / q.z() + cam.cx, v = cam.fy * q.y() / q.z() + cam.cy;
      const int iu = static_cast<int>(std::lround(u)), iv = static_cast<int>(std::lround(v));
      ASSERT_TRUE(iu >= 0 && iu < cam.width && iv >= 0 && iv < cam.height);
      cam.cx += iu - u;
      cam.cy += iv - v;
      // Render the scene, keep only P's pixel.
      DepthImage im = render(scene, cam, 0);
      const std::uint16_t d = im.depth[static_cast<std::size_t>(iv) * cam.width + iu];
      ASSERT_GT(d, 0) << "camera " << k;
      std::fill(im.depth.begin(), im.depth.end(), 0);
      im.depth[static_cast<std::size_t>(iv) * cam.width + iu] = d;
      const CameraCloud out = deproject(im, cam, crop);
      ASSERT_TRUE(out.error.ok()) << out.error.message;
      ASSERT_EQ(out.points.size(), 1u);
      seen[k] = out.points[0];
      // Depth quantisation (0.25 mm counts) is the only error.
      EXPECT_LT((seen[k] - P).norm(), 0.0005) << "camera " << k << " attempt " << attempt;
    }
    EXPECT_LT((seen[0] - seen[1]).norm(), 0.001) << "attempt " << attempt;
    ++checked;
  }
  EXPECT_EQ(checked, 12);
}

// Every deprojected pixel of a rendered frame lies on the scene's surface.
TEST(Deproject, RenderedFrameLiesOnTheSurface) {
  using namespace synthetic;
  const Scene scene = boxScene({0.4, 0.3, 0.2}, 0.08, {Sphere{{0.0, 0.0, 0.08}, 0.04}});
  const Eigen::AlignedBox3d crop = cropBox({0.4, 0.3, 0.2}, 0.01);
  for (const PinholeCamera& cam : defaultRig(320, 240)) {
    const CameraCloud out = deproject(render(scene, cam, 0), cam, crop);
    ASSERT_TRUE(out.error.ok());
    EXPECT_GT(out.points.size(), 320u * 240u / 5);
    double worst = 0;
    for (const Eigen::Vector3d& p : out.points) {
      worst = std::max(worst, scene.distance(p));
      ASSERT_TRUE(crop.contains(p));
    }
    EXPECT_LT(worst, 0.0005) << cam.name;  // half the 0.25 mm depth count, stretched by slant
    EXPECT_EQ(out.counts.kept + out.counts.outside_crop + out.counts.no_return + out.counts.out_of_range,
              out.counts.inputs);
    EXPECT_GT(out.counts.outside_crop, 0u);  // the table around the box
  }
}

TEST(Deproject, CropCountsOnALattice) {
  // A 1 cm lattice, given as camera-frame points of an identity-pose camera (z in range).
  PinholeCamera cam;
  cam.name = "LATTICE";
  Cloud lattice;
  for (int i = -30; i <= 30; ++i)
    for (int j = -30; j <= 30; ++j)
      for (int k = 1; k <= 30; ++k) lattice.emplace_back(0.01 * i, 0.01 * j, 0.01 * k);
  const Eigen::AlignedBox3d crop = cropBox({0.4, 0.3, 0.2}, 0.005);  // x +-0.205, y +-0.155, z -0.005..0.205
  const CameraCloud out = cameraPointsToCell(lattice, cam, crop);
  ASSERT_TRUE(out.error.ok());
  // x: -0.20..0.20 (41 values), y: -0.15..0.15 (31), z: 0.01..0.20 (20).
  EXPECT_EQ(out.points.size(), 41u * 31u * 20u);
  EXPECT_EQ(out.counts.outside_crop, lattice.size() - 41u * 31u * 20u);
}

// The table-driven Deprojector gives exactly deproject()'s points and counts, on noisy frames
// with flying pixels, and rebuilds its tables when the camera moves or the unit changes.
TEST(Deprojector, MatchesDeprojectExactly) {
  using namespace synthetic;
  const Scene scene = boxScene({0.4, 0.3, 0.2}, 0.06, {Sphere{{0.0, 0.02, 0.07}, 0.04}});
  const Eigen::AlignedBox3d crop = cropBox({0.4, 0.3, 0.2}, 0.005);
  std::mt19937 rng(9);
  Noise noise;
  noise.flying_pixel_prob = 0.5;
  auto rig = defaultRig(320, 240);
  rig[0].min_range = 0.6;  // cuts through the box: exercises the range tables
  rig[1].max_range = 0.75;
  Deprojector fast(crop);
  auto same = [&](const DepthImage& im, const PinholeCamera& cam) {
    const CameraCloud a = deproject(im, cam, crop), b = fast(im, cam);
    ASSERT_EQ(a.error.status, b.error.status);
    ASSERT_EQ(a.points.size(), b.points.size());
    for (std::size_t i = 0; i < a.points.size(); ++i) ASSERT_EQ(a.points[i], b.points[i]) << i;
    EXPECT_EQ(a.counts.no_return, b.counts.no_return);
    EXPECT_EQ(a.counts.out_of_range, b.counts.out_of_range);
    EXPECT_EQ(a.counts.outside_crop, b.counts.outside_crop);
    EXPECT_GT(a.counts.out_of_range, 0u);
    EXPECT_GT(a.counts.outside_crop, 0u);
    EXPECT_GT(a.points.size(), 1000u);
  };
  for (int k = 0; k < 3; ++k) same(render(scene, rig[0], k, 0.00025, &noise, &rng), rig[0]);
  EXPECT_EQ(fast.rebuilds(), 1);
  same(render(scene, rig[1], 0, 0.00025, &noise, &rng), rig[1]);
  EXPECT_EQ(fast.rebuilds(), 2);
  same(render(scene, rig[1], 0, 0.001, &noise, &rng), rig[1]);  // 1 mm depth unit
  EXPECT_EQ(fast.rebuilds(), 3);
}

// A header that is valid but extreme (a depth unit of 1e-25 m, a range of 1e6 m): every count's
// closed form lies far beyond a long, which was cast before it was clamped (undefined; found by
// test/fuzz). Both deprojections still agree: the hand frame's returns are all too near.
TEST(Deprojector, ExtremeButFiniteHeaderAgreesWithDeproject) {
  DepthImage im = handImage();
  PinholeCamera cam = handCamera();
  im.depth_unit = 1e-25;
  cam.max_range = 1e6;
  const CameraCloud a = deproject(im, cam, kEverywhere);
  const CameraCloud b = Deprojector(kEverywhere)(im, cam);
  EXPECT_EQ(a.error.status, FrameStatus::kNoValidReturns);
  EXPECT_EQ(b.error.status, FrameStatus::kNoValidReturns);
  EXPECT_EQ(a.counts.out_of_range, 2u);
  EXPECT_EQ(b.counts.out_of_range, 2u);
}
