// Eq. 2 on analytic scenes: a 6 cm cube (bottom 2 cm, top 8 cm) in flat powder, a tube with
// powder inside, the default pipe standing and toppled; plus bad inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "depowder/mesh.hpp"
#include "depowder/parts.hpp"
#include "depowder/progress/progress.hpp"
#include "scenes.hpp"

namespace depowder::progress {
namespace {

using test::boxSurface;
using test::distanceToSquare;
using test::powderPlane;

constexpr double kHalf = 0.03;  // cube half side, m
constexpr double kBottom = 0.02, kTop = 0.08;
constexpr double kXi = 0.01;

Cloud cubeCad() { return boxSurface({-kHalf, -kHalf, kBottom}, {kHalf, kHalf, kTop}, 0.003); }
bool underCube(double x, double y) { return std::abs(x) <= kHalf && std::abs(y) <= kHalf; }

/// Powder at h plus the part surface above it (what a camera from above would see).
Cloud cubeScene(double h, double sigma = 0) {
  Cloud scan = powderPlane(h, 0.15, 0.0025, underCube, sigma);
  for (const Point& p : cubeCad())
    if (p.z() >= h) scan.push_back(p);
  return scan;
}

class CubeEta : public ::testing::TestWithParam<double> {};

TEST_P(CubeEta, Eq2IsExactOnFlatPowder) {
  const double h = GetParam();
  const ProgressEstimate e = estimateProgress(cubeCad(), cubeScene(h), kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_DOUBLE_EQ(e.h_max, kTop);
  EXPECT_DOUBLE_EQ(e.h_min, kBottom);
  EXPECT_NEAR(e.h_pow, h, 1e-12);
  EXPECT_NEAR(e.eta, (kTop - h) / (kTop - kBottom), 1e-9);  // Eq. 2
  EXPECT_GE(e.band.size(), 100u);
  for (const Point& p : e.band) {  // band: (xi, xi + 0.5 cm] from the part in 2-D
    const double d = distanceToSquare(p.x(), p.y(), kHalf);
    EXPECT_GT(d, kXi - 1e-9);
    EXPECT_LE(d, kXi + 0.005 + 1e-9);
  }
}

TEST_P(CubeEta, NoisyPowderWithinHalfAPercent) {
  const double h = GetParam();
  const ProgressEstimate e = estimateProgress(cubeCad(), cubeScene(h, 0.0015), kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  const double truth = std::clamp((kTop - h) / (kTop - kBottom), 0.0, 1.0);
  EXPECT_NEAR(e.eta, truth, 0.005);
}

INSTANTIATE_TEST_SUITE_P(PowderHeights, CubeEta, ::testing::Values(0.02, 0.035, 0.05, 0.065, 0.079));

TEST(Eq2, TruncatesAboveTheTopAndCapsBelowTheBottom) {
  EXPECT_DOUBLE_EQ(etaFromHeights(0.09, kTop, kBottom), 0.0);  // H_pow truncated to H_max
  EXPECT_DOUBLE_EQ(etaFromHeights(0.05, kTop, kBottom), 0.5);
  EXPECT_DOUBLE_EQ(etaFromHeights(0.00, kTop, kBottom), 1.0);
}

TEST(Eq2, PowderBelowTheBottomGivesOne) {
  const ProgressEstimate e = estimateProgress(cubeCad(), cubeScene(0.01), kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_NEAR(e.h_pow, 0.01, 1e-12);
  EXPECT_DOUBLE_EQ(e.eta, 1.0);
}

TEST(Eq2, PowderJustAboveTheTopIsTruncated) {
  // 3 mm above the top, part not visible: H_pow is truncated to H_max, eta = 0.
  const ProgressEstimate e = estimateProgress(cubeCad(), powderPlane(0.083, 0.15, 0.0025, nullptr), kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_TRUE(e.covered);
  EXPECT_NEAR(e.h_pow, 0.083, 1e-12);
  EXPECT_DOUBLE_EQ(e.eta, 0.0);
}

TEST(Covered, FullyCoveredCubeGivesZeroAndAContourAroundIt) {
  const double h = kTop + 0.02;
  const ProgressConfig config;
  const ProgressEstimate e = estimateProgress(cubeCad(), powderPlane(h, 0.15, 0.0025, nullptr), kXi, config);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_TRUE(e.covered);
  EXPECT_DOUBLE_EQ(e.eta, 0.0);

  // The contour: a closed counter-clockwise loop on the band's centre line, at the powder height.
  const double level = kXi + config.band_offset + 0.5 * config.band_width;
  ASSERT_GE(e.contour.size(), 20u);
  double area = 0, max_step = 0;
  for (std::size_t i = 0, j = e.contour.size() - 1; i < e.contour.size(); j = i++) {
    const Point& p = e.contour[i];
    EXPECT_NEAR(distanceToSquare(p.x(), p.y(), kHalf), level, 0.002) << p.transpose();
    EXPECT_NEAR(p.z(), h, 1e-9);
    area += e.contour[j].x() * p.y() - p.x() * e.contour[j].y();
    max_step = std::max(max_step, (p - e.contour[j]).norm());
  }
  EXPECT_GT(area, 0);  // counter-clockwise
  EXPECT_LT(max_step, 1.5 * config.contour_spacing);

  // Segmentation (paper footnote): the powder over the buried top is the part segment.
  EXPECT_GE(e.part_points, 500u);  // (6 cm / 2.5 mm)^2 = 576 points over the top
  for (const Point& p : e.part) EXPECT_LE(distanceToSquare(p.x(), p.y(), kHalf), kXi + 0.003);
}

TEST(Contour, FollowsTheLocalPowderHeight) {
  // Powder sloping along x: z = 0.05 + 0.1 x. Each contour vertex sits at the local height.
  Cloud scan = powderPlane(0.0, 0.15, 0.0025, underCube);
  for (Point& p : scan) p.z() = 0.05 + 0.1 * p.x();
  const ProgressEstimate e = estimateProgress(cubeCad(), scan, kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_NEAR(e.h_pow, 0.05, 0.001);  // symmetric band: the mean is the centre height
  for (const Point& p : e.contour) EXPECT_NEAR(p.z(), 0.05 + 0.1 * p.x(), 0.0015) << p.transpose();
}

TEST(Outliers, NozzlePointsInTheBandAreRejected) {
  const double h = 0.05;
  Cloud scan = cubeScene(h);
  // A nozzle 3 cm above the powder over one side of the band: 40 points, about 15 % of the band.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.02, 0.02), r(kHalf + kXi + 0.0005, kHalf + kXi + 0.0045);
  for (int i = 0; i < 40; ++i) scan.emplace_back(r(rng), u(rng), h + 0.03);
  const ProgressEstimate e = estimateProgress(cubeCad(), scan, kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_GE(e.band_outliers, 40u);
  EXPECT_NEAR(e.eta, (kTop - h) / (kTop - kBottom), 1e-9);
}

TEST(Footprint, PowderInsideAHollowPartIsNotBand) {
  // A tube (outer radius 3 cm, bore 2.5 cm, z 2..8 cm) holding powder up to 7.5 cm inside,
  // with the outside powder at 4 cm. The bore's powder must not count (filled silhouette).
  Cloud cad;
  const double ro = 0.03, ri = 0.025;
  for (int k = 0; k < 120; ++k) {
    const double a = 2 * M_PI * k / 120;
    for (int j = 0; j <= 20; ++j) {
      const double z = kBottom + (kTop - kBottom) * j / 20;
      cad.emplace_back(ro * std::cos(a), ro * std::sin(a), z);
      cad.emplace_back(ri * std::cos(a), ri * std::sin(a), z);
    }
    for (double r = ri; r <= ro + 1e-9; r += 0.0025)
      for (double z : {kBottom, kTop}) cad.emplace_back(r * std::cos(a), r * std::sin(a), z);
  }
  Cloud scan = powderPlane(0.04, 0.15, 0.0025, [&](double x, double y) { return std::hypot(x, y) <= ro; });
  for (const Point& p : powderPlane(0.075, 0.15, 0.0025, [&](double x, double y) { return std::hypot(x, y) >= ri; }))
    scan.push_back(p);
  const ProgressEstimate e = estimateProgress(cad, scan, kXi);
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_NEAR(e.h_pow, 0.04, 1e-12);
  EXPECT_NEAR(e.eta, (kTop - 0.04) / (kTop - kBottom), 1e-9);
}

// The default pipe, upright (11.5 cm tall) and toppled on its side (3 cm tall): eta follows
// the new height range with the powder where it is.
class Pipe : public ::testing::Test {
 protected:
  static Cloud scene(const Cloud& cad, double h) {
    // Powder everywhere except under the part (a 4 mm disc around each projected sample).
    Eigen::AlignedBox2d box;
    for (const Point& p : cad) box.extend(p.head<2>());
    Cloud scan;
    for (const Point& p : powderPlane(h, 0.15, 0.0025, nullptr)) {
      bool under = false;
      if (box.exteriorDistance(p.head<2>()) < 0.004)
        for (const Point& q : cad)
          if ((q.head<2>() - p.head<2>()).squaredNorm() < 0.004 * 0.004) {
            under = true;
            break;
          }
      if (!under) scan.push_back(p);
    }
    for (const Point& p : cad)
      if (p.z() >= h) scan.push_back(p);
    return scan;
  }
  static double truth(const Mesh& mesh, double h) {
    const Eigen::AlignedBox3d b = bounds(mesh);
    return etaFromHeights(h, b.max().z(), b.min().z());
  }
};

TEST_F(Pipe, StandingAndToppledGiveTheirOwnEta) {
  const Mesh pipe = parts::pipe();
  const SurfaceSamples samples = sampleSurface(pipe, 0.003, 11);
  const double half_height = 0.5 * bounds(pipe).sizes().z();
  const double xi = 0.008;
  const Pose standing = makePoseRpy({0, 0, 0.02 + half_height}, 0, 0, 0.3);
  const Eigen::Vector3d lying_size = bounds(transformed(pipe, makePoseRpy({0, 0, 0}, M_PI / 2, 0, 0))).sizes();
  const Pose toppled = makePoseRpy({0.01, 0.02, 0.02 + 0.5 * lying_size.z()}, M_PI / 2, 0, 0.3);

  for (const auto& [pose, h] : {std::pair{standing, 0.06}, std::pair{toppled, 0.035}}) {
    const Cloud cad = transformed(samples.points, pose);
    const ProgressEstimate e = estimateProgress(cad, scene(cad, h), xi);
    ASSERT_EQ(e.status, Status::kOk) << e.reason;
    const double expected = truth(transformed(pipe, pose), h);
    EXPECT_NEAR(e.h_pow, h, 1e-9);
    // H_max / H_min come from 3 mm samples of the curved outer wall: within 1 mm of the mesh.
    EXPECT_NEAR(e.eta, expected, 0.001 / (e.h_max - e.h_min) + 1e-9) << "h = " << h;
    EXPECT_GT(e.eta, 0.2);
    EXPECT_LT(e.eta, 0.8);
  }
}

// EtaEstimator (the tracker's Eq. 2) against estimateProgress on the same input: the default
// parts at rest in powder, at poses and powder heights that give eta from 0.2 to 0.9.
class EtaEstimatorVsEstimateProgress : public Pipe {
 protected:
  struct Case {
    std::string part;
    Pose pose;
    double h;
  };
  static std::vector<Case> cases() {
    std::vector<Case> out;
    for (const std::string& name : parts::names()) {
      const Mesh mesh = parts::byName(name);
      const Eigen::AlignedBox3d b = bounds(mesh);
      const Pose pose = makePoseRpy({0.01, -0.005, 0.02 - b.min().z()}, 0.05, -0.03, 0.7);
      const Eigen::AlignedBox3d posed = bounds(transformed(mesh, pose));
      for (double eta : {0.2, 0.5, 0.9}) out.push_back({name, pose, posed.max().z() - eta * posed.sizes().z()});
    }
    return out;
  }
  static Cloud samples(const std::string& name) { return sampleSurface(parts::byName(name), 0.005, 11).points; }
  /// Powder sloping 15 % along x with 1.5 mm noise, so that which points are in the band matters.
  static Cloud slopedScene(const Cloud& cad, double h) {
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.0015);
    Cloud scan;
    for (Point p : scene(cad, h)) {
      if (p.z() == h) p.z() += 0.15 * p.x() + noise(rng);  // powder (part samples are never exactly at h)
      scan.push_back(p);
    }
    return scan;
  }
};

// A fresh footprint: the same eta, H_pow and band as estimateProgress (to rounding, 1e-12).
TEST_F(EtaEstimatorVsEstimateProgress, SameEtaOnTheSameInput) {
  for (const Case& c : cases()) {
    const Cloud cad = samples(c.part);
    const double xi = 0.01;
    const Cloud scan = slopedScene(transformed(cad, c.pose), c.h);
    const ProgressEstimate full = estimateProgress(transformed(cad, c.pose), scan, xi);
    EtaEstimator estimator(cad, xi);
    const ProgressEstimate e = estimator.estimate(c.pose, scan);
    ASSERT_EQ(full.status, Status::kOk) << c.part << ": " << full.reason;
    ASSERT_EQ(e.status, Status::kOk) << c.part << ": " << e.reason;
    EXPECT_FALSE(estimator.reusedFootprint());
    EXPECT_NEAR(e.eta, full.eta, 1e-12) << c.part << " h " << c.h;
    EXPECT_NEAR(e.h_pow, full.h_pow, 1e-12) << c.part;
    EXPECT_EQ(e.h_max, full.h_max);
    EXPECT_EQ(e.h_min, full.h_min);
    EXPECT_EQ(e.band.size(), full.band.size()) << c.part;
    EXPECT_EQ(e.part_points, full.part_points) << c.part;
    EXPECT_TRUE(e.contour.empty());
    EXPECT_TRUE(e.part.empty());
  }
}

// After a turn about the vertical and a slide (a pushed part), the footprint is reused through
// the 2-D motion: eta within 0.2 percentage points of a fresh estimate (measured: 0.13 at most). A tilt that moves the
// projection by more than footprint_reuse (0.5 mm) rebuilds it: the same eta again.
TEST_F(EtaEstimatorVsEstimateProgress, ReusedFootprintGivesTheSameEta) {
  for (const Case& c : cases()) {
    const Cloud cad = samples(c.part);
    const double xi = 0.01;
    EtaEstimator estimator(cad, xi);
    ASSERT_EQ(estimator.estimate(c.pose, slopedScene(transformed(cad, c.pose), c.h)).status, Status::kOk);

    const Eigen::Vector3d centre = bounds(transformed(cad, c.pose)).center();
    auto turned = [&](double yaw_deg, const Eigen::Vector3d& tilt_axis, double tilt_deg, const Eigen::Vector3d& slide) {
      Pose T = Pose::Identity();
      T.translate(centre + slide);
      T.rotate(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()));
      T.rotate(Eigen::AngleAxisd(tilt_deg * M_PI / 180, tilt_axis.normalized()));
      T.translate(-centre);
      return Pose(T * c.pose);
    };
    const std::pair<Pose, bool> moves[] = {
        {turned(5.0, Eigen::Vector3d::UnitX(), 0.0, {0.004, -0.003, 0.0}), true},  // pushed: turned and slid
        {turned(0.0, Eigen::Vector3d(1, 1, 0), 0.05, {0.0, 0.0, 0.0005}), true},   // tracker jitter
        {turned(20.0, Eigen::Vector3d(1, -1, 0), 0.1, {-0.01, 0.02, 0.0}), true},  // both, drifting
        {turned(0.0, Eigen::Vector3d::UnitY(), 5.0, {0.0, 0.0, 0.0}), false},      // tipped over a little
    };
    for (const auto& [T, reused] : moves) {
      const Cloud posed = transformed(cad, T);
      const Cloud scan = slopedScene(posed, c.h);
      const ProgressEstimate full = estimateProgress(posed, scan, xi);
      const ProgressEstimate e = estimator.estimate(T, scan);
      ASSERT_EQ(full.status, Status::kOk) << c.part << ": " << full.reason;
      ASSERT_EQ(e.status, Status::kOk) << c.part << ": " << e.reason;
      EXPECT_EQ(estimator.reusedFootprint(), reused) << c.part;
      EXPECT_NEAR(e.eta, full.eta, reused ? 0.002 : 1e-12) << c.part << " h " << c.h;
      EXPECT_EQ(e.h_max, full.h_max);
      EXPECT_EQ(e.h_min, full.h_min);
      EXPECT_NEAR(double(e.band.size()), double(full.band.size()), 0.02 * full.band.size()) << c.part;
    }
  }
}

TEST(EtaEstimator, BadInput) {
  const Cloud cad = cubeCad();
  EtaEstimator estimator(cad, kXi);
  Pose nan_pose = Pose::Identity();
  nan_pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  ProgressEstimate e = estimator.estimate(nan_pose, cubeScene(0.05));
  EXPECT_EQ(e.status, Status::kNoPose);
  EXPECT_NE(e.reason.find("NaN"), std::string::npos) << e.reason;
  EXPECT_EQ(estimator.estimate(Pose::Identity(), {}).status, Status::kNoPoints);
  EXPECT_EQ(EtaEstimator({}, kXi).estimate(Pose::Identity(), cubeScene(0.05)).status, Status::kNoPose);
  EXPECT_EQ(EtaEstimator(cad, -1.0).estimate(Pose::Identity(), cubeScene(0.05)).status, Status::kBadConfig);
  ProgressConfig bad;
  bad.footprint_reuse = -0.001;
  e = EtaEstimator(cad, kXi, bad).estimate(Pose::Identity(), cubeScene(0.05));
  EXPECT_EQ(e.status, Status::kBadConfig);
  EXPECT_NE(e.reason.find("footprint_reuse"), std::string::npos) << e.reason;
  // Still good after bad calls; copies keep working on their own.
  e = estimator.estimate(Pose::Identity(), cubeScene(0.05));
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_NEAR(e.eta, 0.5, 1e-9);
  EtaEstimator copy = estimator;
  estimator = EtaEstimator();
  e = copy.estimate(Pose::Identity(), cubeScene(0.04));
  ASSERT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_TRUE(copy.reusedFootprint());
  EXPECT_NEAR(e.eta, (kTop - 0.04) / (kTop - kBottom), 1e-9);
}

TEST(BadInput, EmptyBandNaNPoseEmptyCloudAndBadXi) {
  const Cloud cad = cubeCad();
  // Powder only far from the part: no band.
  const Cloud far = powderPlane(0.05, 0.15, 0.0025, [](double x, double y) { return std::abs(x) < 0.1; });
  ProgressEstimate e = estimateProgress(cad, far, kXi);
  EXPECT_EQ(e.status, Status::kNoContour);
  EXPECT_NE(e.reason.find("band"), std::string::npos) << e.reason;
  EXPECT_DOUBLE_EQ(e.h_max, kTop);  // heights are still reported

  // Only the part itself in the scan: no band either.
  e = estimateProgress(cad, cad, kXi);
  EXPECT_EQ(e.status, Status::kNoContour);
  EXPECT_EQ(e.part_points, cad.size());

  Cloud nan_cad = cad;
  nan_cad[5].x() = std::numeric_limits<double>::quiet_NaN();
  e = estimateProgress(nan_cad, cubeScene(0.05), kXi);
  EXPECT_EQ(e.status, Status::kNoPose);
  EXPECT_NE(e.reason.find("NaN"), std::string::npos) << e.reason;
  EXPECT_EQ(estimateProgress({}, cubeScene(0.05), kXi).status, Status::kNoPose);
  EXPECT_EQ(estimateProgress(Cloud{Point(0, 0, 0), Point(1, 0, 0)}, cubeScene(0.05), kXi).status, Status::kNoPose);

  e = estimateProgress(cad, {}, kXi);
  EXPECT_EQ(e.status, Status::kNoPoints);
  EXPECT_NE(e.reason.find("empty"), std::string::npos) << e.reason;
  const Cloud nan_scan(100, Point::Constant(std::numeric_limits<double>::quiet_NaN()));
  e = estimateProgress(cad, nan_scan, kXi);
  EXPECT_EQ(e.status, Status::kNoPoints);
  EXPECT_NE(e.reason.find("NaN"), std::string::npos) << e.reason;

  // NaN scan points among good ones are skipped.
  Cloud mixed = cubeScene(0.05);
  mixed.insert(mixed.begin(), nan_scan.begin(), nan_scan.end());
  e = estimateProgress(cad, mixed, kXi);
  EXPECT_EQ(e.status, Status::kOk) << e.reason;
  EXPECT_NEAR(e.eta, 0.5, 1e-9);

  e = estimateProgress(cad, cubeScene(0.05), std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(e.status, Status::kBadConfig);
  EXPECT_NE(e.reason.find("xi"), std::string::npos) << e.reason;
  ProgressConfig bad;
  bad.band_width = -0.001;
  e = estimateProgress(cad, cubeScene(0.05), kXi, bad);
  EXPECT_EQ(e.status, Status::kBadConfig);
  EXPECT_NE(e.reason.find("band_width"), std::string::npos) << e.reason;
}

}  // namespace
}  // namespace depowder::progress
