// Camera extrinsics refined against the build box: ground truth from the analytic scene
// (synthetic.hpp), first guesses off by seeded errors of up to 2 cm and 2 deg.
#include <gtest/gtest.h>

#include <random>

#include "depowder/perception/box_calibration.hpp"
#include "depowder/perception/depth.hpp"
#include "synthetic.hpp"

using namespace depowder;
using namespace depowder::perception;

namespace {

const Eigen::Vector3d kBox(0.40, 0.30, 0.20);  // config/cell.yaml
constexpr double kWall = 0.01;
const Eigen::AlignedBox3d kEverywhere(Eigen::Vector3d::Constant(-100), Eigen::Vector3d::Constant(100));

// The camera's points in its own frame, rendered from its true pose: one exact frame, or the
// median of `frames` frames with the cell's L515 noise (1 mm + 2.5 mm per m).
Cloud cameraPoints(const synthetic::Scene& scene, const PinholeCamera& truth, std::mt19937* rng, int frames = 10) {
  const synthetic::Noise noise;
  std::vector<DepthImage> images;
  for (int k = 0; k < (rng ? frames : 1); ++k)
    images.push_back(synthetic::render(scene, truth, k, 0.00025, rng ? &noise : nullptr, rng));
  const DepthImage image = medianDepth(images);
  PinholeCamera at_origin = truth;
  at_origin.T_cell_camera = Pose::Identity();
  return deproject(image, at_origin, kEverywhere).points;
}

// T_true moved by up to `shift` (m) and turned by up to `turn_deg` about a random axis.
Pose perturbed(const Pose& T_true, double shift, double turn_deg, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  Pose error = Pose::Identity();
  error.linear() = Eigen::AngleAxisd(turn_deg * M_PI / 180 * std::abs(u(rng)), axis).matrix();
  error.translation() = shift * Eigen::Vector3d(u(rng), u(rng), u(rng)) / std::sqrt(3.0);
  return error * T_true;
}

PinholeCamera cellCamera(const std::string& name, double y) {
  return synthetic::makeCamera(name, 320, 240, lookAt({0.0, y, 0.75}, {0.0, 0.0, 0.05}));
}

}  // namespace

TEST(BoxCalibration, ExactScanGivesTheTruePose) {
  const synthetic::Scene scene = synthetic::boxScene(kBox, 0.08, {});
  const PinholeCamera truth = cellCamera("LEFT", -0.35);
  std::mt19937 rng(3);
  const BoxCalibration c = calibrateAgainstBox(cameraPoints(scene, truth, nullptr),
                                               perturbed(truth.T_cell_camera, 0.02, 2, rng), kBox, kWall);
  ASSERT_TRUE(c.ok) << c.problem;
  // Without noise only the 0.25 mm depth quantisation is left.
  EXPECT_LT(translationDistance(c.T_cell_camera, truth.T_cell_camera), 0.0002);
  EXPECT_LT(rotationDistanceDeg(c.T_cell_camera, truth.T_cell_camera), 0.02);
  EXPECT_NEAR(c.powder_level, 0.08, 0.0002);
  EXPECT_LT(c.median_after, 0.0002);
}

// Both of the cell's cameras, each from eight first guesses, ten frames with the L515's noise,
// two parts (spheres) standing out of the powder.
TEST(BoxCalibration, NoisyScansWithPartsInViewFromWrongGuesses) {
  const synthetic::Scene scene =
      synthetic::boxScene(kBox, 0.08, {{{0.05, 0.02, 0.09}, 0.04}, {{-0.1, -0.05, 0.07}, 0.03}});
  std::mt19937 rng(11);
  for (const PinholeCamera& truth : {cellCamera("LEFT", -0.35), cellCamera("RIGHT", 0.35)}) {
    const Cloud points = cameraPoints(scene, truth, &rng);
    for (int trial = 0; trial < 8; ++trial) {
      const Pose guess = perturbed(truth.T_cell_camera, 0.02, 2, rng);
      const BoxCalibration c = calibrateAgainstBox(points, guess, kBox, kWall);
      ASSERT_TRUE(c.ok) << truth.name << " trial " << trial << ": " << c.problem;
      // Measured: 0.33 mm / 0.009 deg (LEFT) and 0.39 mm / 0.011 deg (RIGHT) from every guess.
      EXPECT_LT(translationDistance(c.T_cell_camera, truth.T_cell_camera), 0.0006) << truth.name << " trial " << trial;
      EXPECT_LT(rotationDistanceDeg(c.T_cell_camera, truth.T_cell_camera), 0.03) << truth.name << " trial " << trial;
      EXPECT_NEAR(c.powder_level, 0.08, 0.0005);
      EXPECT_LT(c.median_after, c.median_before);
      EXPECT_LT(c.sigma_t.maxCoeff(), 0.0005);
    }
  }
}

TEST(BoxCalibration, PowderAloneLeavesTheCameraUnpinned) {
  // 32 cm above the powder, looking straight down with a 20 deg field: nothing but powder.
  const synthetic::Scene scene = synthetic::boxScene(kBox, 0.08, {});
  const PinholeCamera truth =
      synthetic::makeCamera("DOWN", 320, 240, lookAt({0.0, 0.001, 0.40}, {0.0, 0.0, 0.0}), 20, 15);
  const BoxCalibration c = calibrateAgainstBox(cameraPoints(scene, truth, nullptr), truth.T_cell_camera, kBox, kWall);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.problem.find("pin the camera"), std::string::npos) << c.problem;
  EXPECT_NE(c.problem.find("two walls that meet"), std::string::npos) << c.problem;
}

TEST(BoxCalibration, BadInputsSayWhatIsWrong) {
  const synthetic::Scene scene = synthetic::boxScene(kBox, 0.08, {});
  const PinholeCamera truth = cellCamera("LEFT", -0.35);
  const Cloud points = cameraPoints(scene, truth, nullptr);
  Pose nan_pose = truth.T_cell_camera;
  nan_pose.translation().x() = std::nan("");
  EXPECT_NE(calibrateAgainstBox(points, nan_pose, kBox, kWall).problem.find("not a finite rigid transform"),
            std::string::npos);
  EXPECT_NE(calibrateAgainstBox({}, truth.T_cell_camera, kBox, kWall).problem.find("no powder surface"),
            std::string::npos);
  // A first guess half a metre off: the box is not where the points are.
  Pose far = truth.T_cell_camera;
  far.translation().x() += 0.5;
  const BoxCalibration c = calibrateAgainstBox(points, far, kBox, kWall);
  EXPECT_FALSE(c.ok);
  EXPECT_FALSE(c.problem.empty());
}

// A camera that switches mode while its frames are collected: the frames start over at the new
// mode, so the median is of those alone (the pixel values are the medians to expect).
TEST(BoxCalibration, FramesOfAnotherModeStartTheMedianOver) {
  auto frame = [](int width, int height, double unit, std::uint16_t z) {
    DepthImage d;
    d.width = width;
    d.height = height;
    d.depth_unit = unit;
    d.depth.assign(static_cast<std::size_t>(width) * height, z);
    return d;
  };
  std::vector<DepthImage> frames;
  EXPECT_EQ(addMedianFrame(frames, frame(4, 3, 0.00025, 1000)), 0u);
  EXPECT_EQ(addMedianFrame(frames, frame(4, 3, 0.00025, 1010)), 0u);
  EXPECT_EQ(addMedianFrame(frames, frame(4, 3, 0.00025, 1020)), 0u);
  EXPECT_EQ(medianDepth(frames).depth.at(5), 1010);
  EXPECT_EQ(addMedianFrame(frames, frame(8, 6, 0.00025, 2000)), 3u);  // the resolution changed
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(addMedianFrame(frames, frame(8, 6, 0.00025, 2004)), 0u);
  EXPECT_EQ(addMedianFrame(frames, frame(8, 6, 0.00025, 2002)), 0u);
  const DepthImage merged = medianDepth(frames);
  ASSERT_EQ(merged.depth.size(), 48u);
  EXPECT_EQ(merged.depth[47], 2002);
  EXPECT_EQ(addMedianFrame(frames, frame(8, 6, 0.0005, 1001)), 3u);  // the depth unit changed
  EXPECT_EQ(frames.size(), 1u);
  EXPECT_EQ(medianDepth(frames).depth_unit, 0.0005);
}
