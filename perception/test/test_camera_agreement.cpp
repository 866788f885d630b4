// Two cameras' powder heights compared: ground truth from the analytic scene (synthetic.hpp),
// one camera deprojected with a pose off its true one by a known turn or rise.
#include <gtest/gtest.h>

#include <random>

#include "depowder/perception/camera_agreement.hpp"
#include "depowder/perception/depth.hpp"
#include "synthetic.hpp"

using namespace depowder;
using namespace depowder::perception;

namespace {

const Eigen::Vector3d kBox(0.40, 0.30, 0.20);

// The points of a camera at `truth` (one noisy frame), deprojected as if it were at `claimed`.
Cloud seen(const synthetic::Scene& scene, const Pose& truth, const Pose& claimed, std::mt19937& rng) {
  PinholeCamera c = synthetic::makeCamera("C", 320, 240, truth);
  const synthetic::Noise noise;
  const DepthImage image = synthetic::render(scene, c, 0, 0.00025, &noise, &rng);
  c.T_cell_camera = claimed;
  return deproject(image, c, cropBox(kBox, 0.005)).points;
}

// `T` turned by `deg` about the cell axis `axis` through the camera's centre, then raised by `rise`.
Pose moved(const Pose& T, const Eigen::Vector3d& axis, double deg, double rise) {
  Pose out = T;
  out.linear() = Eigen::AngleAxisd(deg * M_PI / 180, axis).matrix() * T.linear();
  out.translation().z() += rise;
  return out;
}

struct Rig {
  synthetic::Scene scene = synthetic::boxScene(kBox, 0.08, {{{0.05, 0.02, 0.09}, 0.04}, {{-0.1, -0.05, 0.07}, 0.03}});
  Pose left = lookAt({0.0, -0.35, 0.75}, {0.0, 0.0, 0.05});
  Pose right = lookAt({0.0, 0.35, 0.75}, {0.0, 0.0, 0.05});
  std::mt19937 rng{5};
};

}  // namespace

TEST(CameraAgreement, CamerasWhereTheySayAgree) {
  Rig r;
  const Agreement a = compareHeights(seen(r.scene, r.left, r.left, r.rng), seen(r.scene, r.right, r.right, r.rng), kBox,
                                     AgreementConfig{});
  ASSERT_TRUE(a.valid);
  EXPECT_GT(a.cells, 300);
  EXPECT_LT(std::abs(a.offset), 0.0003) << a.offset;
  EXPECT_LT(a.tilt_deg, 0.05);
}

TEST(CameraAgreement, ATurnAboutAHorizontalAxisIsItsTilt) {
  // LEFT's frames say it is turned 1 deg about x from where it is: the heights it gives change
  // by 1 deg x (y - y_camera), 6.1 mm at the box centre 0.35 m from it.
  Rig r;
  const Pose claimed = moved(r.left, Eigen::Vector3d::UnitX(), 1.0, 0.0);
  const Agreement a = compareHeights(seen(r.scene, r.left, claimed, r.rng), seen(r.scene, r.right, r.right, r.rng),
                                     kBox, AgreementConfig{});
  ASSERT_TRUE(a.valid);
  EXPECT_NEAR(a.tilt_deg, 1.0, 0.05);
  EXPECT_NEAR(a.offset, 0.35 * M_PI / 180, 0.0005);
}

TEST(CameraAgreement, ARiseIsItsOffsetAndASlideDoesNotShow) {
  Rig r;
  const Cloud right = seen(r.scene, r.right, r.right, r.rng);
  const Agreement rise =
      compareHeights(seen(r.scene, r.left, moved(r.left, Eigen::Vector3d::UnitX(), 0, 0.003), r.rng), right, kBox, {});
  EXPECT_NEAR(rise.offset, 0.003, 0.0003);
  EXPECT_LT(rise.tilt_deg, 0.05);
  Pose slid = r.left;
  slid.translation().x() += 0.005;
  const Agreement slide = compareHeights(seen(r.scene, r.left, slid, r.rng), right, kBox, {});
  EXPECT_LT(std::abs(slide.offset), 0.0005);
}

TEST(CameraAgreement, TooFewSharedCellsGiveNoFigure) {
  Rig r;
  const Cloud right = seen(r.scene, r.right, r.right, r.rng);
  EXPECT_FALSE(compareHeights({}, right, kBox, {}).valid);
  EXPECT_FALSE(compareHeights(right, right, {0.03, 0.03, 0.2}, {}).valid);  // nothing inside the margins
}
