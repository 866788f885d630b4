// registerSurfaces: recovers known rigid motions of the default parts, skips a thin wall's other
// face, keeps a prior where the scan sees nothing, orients scan normals to the camera, refuses bad
// input with a reason, and never returns an invalid pose. visibleTemplate's cover test.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "depowder/mesh.hpp"
#include "depowder/parts.hpp"
#include "depowder/tracker/registration.hpp"
#include "depowder/tracker/template.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

double rotErrDeg(const Pose& a, const Pose& b) { return rotationAngle(a.linear(), b.linear()) * 180.0 / M_PI; }
double transErrMm(const Pose& a, const Pose& b) { return translationDistance(a, b) * 1000.0; }

// A one-off registration (no prior), converged to the given steps.
IcpConfig oneOff(int max_iterations, double convergence_translation, double convergence_rotation) {
  IcpConfig config;
  config.max_iterations = max_iterations;
  config.convergence_translation = convergence_translation;
  config.convergence_rotation = convergence_rotation;
  return config;
}

class KnownMotion : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    mesh_ = parts::byName(GetParam());
    cad_ = sampleSurface(mesh_, 0.0025, 1);
    const Indices icp = thinned(cad_.points, allIndices(cad_.points.size()), 0.005);  // as the tracker thins
    src_ = gather(cad_.points, icp);
    src_n_ = gather(cad_.normals, icp);
  }
  // A guess 5.4 mm and ~4.3 deg from the true motion.
  const Pose T_true_ = makePoseRpy({0.1 + 0.004, -0.05 - 0.003, 0.06 + 0.002}, 0.04, -0.03, 0.05);
  const Pose guess_ = makePoseRpy({0.1, -0.05, 0.06}, 0, 0, 0);
  Mesh mesh_;
  SurfaceSamples cad_;
  Cloud src_, src_n_;
};

// The sampled mesh moved by T_true, no noise: the motion must come back to 0.1 deg / 0.5 mm
// (the tolerance), with each of the data terms.
TEST_P(KnownMotion, RecoveredWithoutNoise) {
  struct Variant {
    const char* name;
    double tangent_weight, scan_weight;
  };
  for (const Variant v : {Variant{"both ways, point-to-point", 1, 1}, Variant{"point-to-plane, template only", 0, 0},
                          Variant{"point-to-point, template only", 1, 0}}) {
    IcpConfig config = oneOff(50, 1e-6, 1e-5);
    config.tangent_weight = v.tangent_weight;
    config.scan_weight = v.scan_weight;
    const RegistrationResult r = registerSurfaces(src_, src_n_, transformed(cad_.points, T_true_),
                                                  rotated(cad_.normals, T_true_), guess_, 0.015, config);
    ASSERT_TRUE(r.ok()) << r.reason;
    EXPECT_EQ(r.status, RegistrationStatus::kConverged) << v.name;
    EXPECT_LT(rotErrDeg(r.T_target_source, T_true_), 0.1) << GetParam() << ", " << v.name;
    EXPECT_LT(transErrMm(r.T_target_source, T_true_), 0.5) << GetParam() << ", " << v.name;
    EXPECT_GT(r.inlier_ratio, 0.99);
    EXPECT_LT(r.rms, 1e-4);
    EXPECT_TRUE(isValidPose(r.T_target_source, 1e-9));
  }
}

// A different, denser sampling of the mesh as the target: points no longer coincide, so the
// point-to-point part of the cost leaves a sampling offset (measured: 0.19 deg, 0.10 mm at most).
TEST_P(KnownMotion, RecoveredFromAnIndependentSampling) {
  const IcpConfig config = oneOff(50, 1e-6, 1e-5);
  const SurfaceSamples target = sampleSurface(mesh_, 0.001, 2);
  const RegistrationResult r = registerSurfaces(src_, src_n_, transformed(target.points, T_true_),
                                                rotated(target.normals, T_true_), guess_, 0.015, config);
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_LT(rotErrDeg(r.T_target_source, T_true_), 0.3) << GetParam();
  EXPECT_LT(transErrMm(r.T_target_source, T_true_), 0.3) << GetParam();
}

// 1 mm noise and outliers (a quarter, then a half of the target, uniform in the part's box,
// with normals in random directions): association within 1 cm between agreeing normals and the
// Geman-McClure kernel keep every part within 1 deg / 1 mm from a 3.1 deg, 5.4 mm guess.
TEST_P(KnownMotion, RobustToOutliersAndNoise) {
  const IcpConfig config = oneOff(50, 1e-5, 1e-4);
  const Pose T_true = makePoseRpy({0.003, 0.002, -0.004}, 0.02, 0.03, -0.04);
  for (const double fraction : {0.25, 0.5}) {
    const SurfaceSamples samples = sampleSurface(mesh_, 0.002, 7);
    Cloud target = transformed(samples.points, T_true), normals = rotated(samples.normals, T_true);
    std::mt19937 rng(42);
    std::normal_distribution<double> noise(0.0, 0.001);
    for (Point& p : target) p += Point(noise(rng), noise(rng), noise(rng));
    const Eigen::AlignedBox3d box = bounds(target);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const std::size_t n_out = static_cast<std::size_t>(fraction * target.size());
    for (std::size_t i = 0; i < n_out; ++i) {
      target.push_back(box.min() + box.sizes().cwiseProduct(Point(u(rng), u(rng), u(rng))));
      normals.push_back(Eigen::Vector3d(noise(rng), noise(rng), noise(rng)).normalized());
    }
    const RegistrationResult r = registerSurfaces(src_, src_n_, target, normals, Pose::Identity(), 0.01, config);
    ASSERT_TRUE(r.ok()) << r.reason;
    EXPECT_LT(rotErrDeg(r.T_target_source, T_true), 1.0) << GetParam() << ", outliers " << fraction;
    EXPECT_LT(transErrMm(r.T_target_source, T_true), 1.0) << GetParam() << ", outliers " << fraction;
  }
}

INSTANTIATE_TEST_SUITE_P(DefaultParts, KnownMotion, ::testing::Values("cube", "cup", "propeller", "owl", "pipe"));

// Matches need agreeing normals (icp.normal_min_cos): the cube's samples with their normals
// turned inside out (a thin wall's other face, seen from the other side) pair with nothing; with
// the test off they pair as before.
TEST(Registration, PointsWithDisagreeingNormalsAreNotMatched) {
  const SurfaceSamples cad = sampleSurface(parts::byName("cube"), 0.005, 1);
  Cloud flipped = cad.normals;
  for (Eigen::Vector3d& n : flipped) n = -n;
  IcpConfig config;
  const RegistrationResult with =
      registerSurfaces(cad.points, cad.normals, cad.points, flipped, Pose::Identity(), 0.01, config);
  EXPECT_EQ(with.status, RegistrationStatus::kTooFewCorrespondences);
  EXPECT_EQ(with.correspondences, 0);
  config.normal_min_cos = -1;
  const RegistrationResult without =
      registerSurfaces(cad.points, cad.normals, cad.points, flipped, Pose::Identity(), 0.01, config);
  EXPECT_EQ(without.status, RegistrationStatus::kConverged);
  EXPECT_EQ(without.correspondences, static_cast<int>(cad.points.size()));
}

// Scan points marked as not pulling (Surface::pulls: the tracker's powder by the part) are
// matched by the template's points but are not matched to the template themselves.
TEST(Registration, ScanPointsThatDoNotPullAreMatchedOneWayOnly) {
  Cloud patch, up;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) patch.emplace_back(0.005 * i, 0.005 * j, 0.0), up.emplace_back(0, 0, 1);
  Cloud powder = patch;
  for (Point& p : powder) p.z() += 0.003;
  const ScanIndex model_index(patch, 0.01), scan_index(powder, 0.01);
  const std::vector<std::uint8_t> all(powder.size(), 1), none(powder.size(), 0);
  const IcpConfig config = oneOff(1, 1e-9, 1e-9);
  const RegistrationResult both =
      registerSurfaces({patch, up, model_index}, {powder, up, scan_index, &all}, Pose::Identity(), 0.01, config);
  const RegistrationResult one_way =
      registerSurfaces({patch, up, model_index}, {powder, up, scan_index, &none}, Pose::Identity(), 0.01, config);
  EXPECT_EQ(both.correspondences, 100);
  EXPECT_EQ(both.scan_matches, 100);
  EXPECT_EQ(one_way.correspondences, 100);
  EXPECT_EQ(one_way.scan_matches, 0);
}

// visibleTemplate's cover test: an upward face with a scan point 3-15 mm straight over it is under
// powder; an upward face level with the scan, a side face, and a face whose scan point is higher
// than that column are kept.
TEST(VisibleTemplate, UpwardFaceUnderPowderIsLeftOut) {
  const Cloud points{{0, 0, 0}, {0.05, 0, 0}, {0.1, 0, 0}, {0.15, 0, 0}};
  const Cloud normals{{0, 0, 1}, {0, 0, 1}, {1, 0, 0}, {0, 0, 1}};
  const Cloud scan{{0.001, 0, 0.005}, {0.05, 0.001, 0.0005}, {0.1, 0, 0.005}, {0.15, 0, 0.02}};
  const ScanIndex index(scan, 0.01);
  const std::vector<Point> eyes{{0.5, 0, 1}};
  Cloud out, out_n;
  visibleTemplate(points, normals, Pose::Identity(), eyes, PowderHeights(), 0, &index, 0.003, out, out_n);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0], points[1]);
  EXPECT_EQ(out[1], points[2]);
  EXPECT_EQ(out[2], points[3]);
  EXPECT_EQ(out_n[1], normals[2]);
  visibleTemplate(points, normals, Pose::Identity(), eyes, PowderHeights(), 0, &index, 0.0, out, out_n);
  EXPECT_EQ(out.size(), 4u);  // cover 0: no cover test
  visibleTemplate(points, normals, Pose::Identity(), eyes, PowderHeights(), 0, nullptr, 0.003, out, out_n);
  EXPECT_EQ(out.size(), 4u);  // no scan given
  // The same at a pose: the test is in the cell frame.
  const Pose T = makePoseRpy({0.2, 0.1, 0.05}, 0, 0, 0.5);
  Cloud moved = scan;
  for (Point& p : moved) p = T * p;
  const ScanIndex moved_index(moved, 0.01);
  visibleTemplate(points, normals, T, {T * eyes[0]}, PowderHeights(), 0, &moved_index, 0.003, out, out_n);
  EXPECT_EQ(out.size(), 3u);
}

// A prior holds what the scan cannot see: a flat square's slide in its own plane. Across the
// plane the scan wins; along it the fit stays at the prior's pose.
TEST(Registration, APriorHoldsWhatTheScanCannotSee) {
  Cloud plate, up;
  for (double x = -0.04; x <= 0.04; x += 0.004)
    for (double y = -0.04; y <= 0.04; y += 0.004) {
      plate.emplace_back(x, y, 0.0);
      up.emplace_back(0, 0, 1);
    }
  const Cloud scan = transformed(plate, makePoseRpy({0.0011, 0.0017, 0.002}, 0, 0, 0));  // 2 mm up, slid
  const ScanIndex model_index(plate, 0.01), scan_index(scan, 0.01);
  IcpConfig config = oneOff(50, 1e-7, 1e-6);
  config.tangent_weight = 0;  // point-to-plane: the slide is not seen at all
  PosePrior prior;
  prior.T_cell_part = makePoseRpy({0.001, 0.001, 0.0}, 0, 0, 0);
  prior.information = Matrix6d::Identity() * 1e6;
  const RegistrationResult r =
      registerSurfaces({plate, up, model_index}, {scan, up, scan_index}, Pose::Identity(), 0.01, config, &prior);
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_NEAR(r.T_target_source.translation().z(), 0.002, 1e-5);  // across: the scan
  EXPECT_NEAR(r.T_target_source.translation().x(), 0.001, 1e-5);  // along: the prior
  EXPECT_NEAR(r.T_target_source.translation().y(), 0.001, 1e-5);
  EXPECT_LT(rotErrDeg(r.T_target_source, Pose::Identity()), 1e-3);
}

// The disagreement check's second fit from the same guess reuses the first fit's first-round
// matches: with and without a prior it ends exactly where a fresh search ends; from another guess
// the stored matches are not used (the fit is the fresh one, and they are replaced).
TEST(Registration, FirstMatchesGiveTheSameFit) {
  const SurfaceSamples cad = sampleSurface(parts::byName("cup"), 0.004, 1);
  const Pose T_true = makePoseRpy({0.003, -0.002, 0.001}, 0.03, -0.02, 0.04);
  const Cloud scan = transformed(cad.points, T_true);
  Cloud scan_n;
  for (const auto& n : cad.normals) scan_n.push_back(T_true.linear() * n);
  const ScanIndex model_index(cad.points, 0.01), scan_index(scan, 0.01);
  const Surface model{cad.points, cad.normals, model_index}, target{scan, scan_n, scan_index};
  PosePrior prior;
  prior.information = Matrix6d::Identity() * 1e4;
  const IcpConfig config = oneOff(30, 1e-6, 1e-5);
  for (const Pose& guess : {Pose::Identity(), makePoseRpy({0.001, 0, 0}, 0, 0, 0.01)}) {
    const RegistrationResult fresh = registerSurfaces(model, target, guess, 0.01, config, nullptr);
    FirstMatches first;
    const RegistrationResult filtered = registerSurfaces(model, target, guess, 0.01, config, &prior, &first);
    ASSERT_TRUE(first.filled);
    EXPECT_TRUE(first.T.isApprox(guess, 1e-12));
    const RegistrationResult reused = registerSurfaces(model, target, guess, 0.01, config, nullptr, &first);
    ASSERT_TRUE(fresh.ok() && filtered.ok() && reused.ok()) << fresh.reason << filtered.reason << reused.reason;
    EXPECT_TRUE(reused.T_target_source.isApprox(fresh.T_target_source, 1e-12));
    EXPECT_EQ(reused.iterations, fresh.iterations);
    EXPECT_EQ(reused.associations, fresh.associations);
    EXPECT_EQ(reused.correspondences, fresh.correspondences);
    EXPECT_LT(rotErrDeg(reused.T_target_source, T_true), 0.1);
  }
  // Stored at one guess, asked at another: searched again.
  FirstMatches first;
  registerSurfaces(model, target, Pose::Identity(), 0.01, config, nullptr, &first);
  const Pose other = makePoseRpy({0.006, 0, 0}, 0, 0, 0.05);
  const RegistrationResult fresh = registerSurfaces(model, target, other, 0.01, config, nullptr);
  const RegistrationResult again = registerSurfaces(model, target, other, 0.01, config, nullptr, &first);
  EXPECT_TRUE(again.T_target_source.isApprox(fresh.T_target_source, 1e-12));
  EXPECT_TRUE(first.T.isApprox(other, 1e-12));
}

// Normals of a noisy plane seen from above point up; seen from below, down.
TEST(Registration, ScanNormalsFaceTheCamera) {
  Cloud plane;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.0005);
  for (double x = -0.05; x <= 0.05; x += 0.005)
    for (double y = -0.05; y <= 0.05; y += 0.005) plane.emplace_back(x, y, 0.1 * x + noise(rng));
  const ScanIndex index(plane, 0.01);
  const Eigen::Vector3d truth = Eigen::Vector3d(-0.1, 0, 1).normalized();
  for (const double side : {1.0, -1.0}) {
    const Cloud n = scanNormals(index, {Point(0.2, 0.1, side * 0.8)}, 0.012);
    ASSERT_EQ(n.size(), plane.size());
    double worst = 1;
    for (const Eigen::Vector3d& v : n) worst = std::min(worst, side * v.dot(truth));
    EXPECT_GT(worst, std::cos(10 * M_PI / 180)) << "camera side " << side;  // within 10 deg, facing the camera
  }
  // A lone point has no normal (it matches nothing).
  const ScanIndex lone(Cloud{Point(0, 0, 0)}, 0.01);
  EXPECT_EQ(scanNormals(lone, {}, 0.01).front(), Eigen::Vector3d::Zero());
}

// Identical source and target: one round finds a zero update and stops.
TEST(Registration, StopsAtOnceWhenAligned) {
  const SurfaceSamples cad = sampleSurface(parts::byName("cube"), 0.005, 1);
  const RegistrationResult r =
      registerSurfaces(cad.points, cad.normals, cad.points, cad.normals, Pose::Identity(), 0.01, IcpConfig{});
  EXPECT_EQ(r.status, RegistrationStatus::kConverged);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_NEAR(r.inlier_ratio, 1.0, 1e-12);
  EXPECT_LT(rotErrDeg(r.T_target_source, Pose::Identity()), 1e-6);
}

TEST(Registration, TooFewCorrespondencesReturnsTheGuess) {
  const SurfaceSamples cad = sampleSurface(parts::byName("cube"), 0.005, 1);
  const Cloud far = transformed(cad.points, makePoseRpy({1.0, 0, 0}, 0, 0, 0));  // 1 m away
  const Pose guess = makePoseRpy({0.01, 0.02, 0.03}, 0.1, 0.2, 0.3);
  const RegistrationResult r = registerSurfaces(cad.points, cad.normals, far, cad.normals, guess, 0.01, IcpConfig{});
  EXPECT_EQ(r.status, RegistrationStatus::kTooFewCorrespondences);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.reason.find("template points"), std::string::npos) << r.reason;
  EXPECT_TRUE(r.T_target_source.isApprox(guess, 1e-12));
}

TEST(Registration, InvalidInputIsNamed) {
  const SurfaceSamples cad = sampleSurface(parts::byName("cube"), 0.005, 1);
  const IcpConfig config;
  auto reasonFor = [&](const Cloud& src, const Cloud& nrm, const Cloud& tgt, const Cloud& tgt_n, const Pose& guess,
                       double d) {
    const RegistrationResult r = registerSurfaces(src, nrm, tgt, tgt_n, guess, d, config);
    EXPECT_EQ(r.status, RegistrationStatus::kInvalidInput);
    EXPECT_TRUE(isValidPose(r.T_target_source));
    return r.reason;
  };
  const Cloud& p = cad.points;
  const Cloud& n = cad.normals;
  EXPECT_NE(reasonFor({}, {}, p, n, Pose::Identity(), 0.01).find("source"), std::string::npos);
  EXPECT_NE(reasonFor(p, {}, p, n, Pose::Identity(), 0.01).find("normals"), std::string::npos);
  EXPECT_NE(reasonFor(p, n, {}, {}, Pose::Identity(), 0.01).find("target"), std::string::npos);
  EXPECT_NE(reasonFor(p, n, p, {}, Pose::Identity(), 0.01).find("target has"), std::string::npos);
  Pose nan_guess = Pose::Identity();
  nan_guess.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(reasonFor(p, n, p, n, nan_guess, 0.01).find("guess"), std::string::npos);
  EXPECT_NE(reasonFor(p, n, p, n, Pose::Identity(), -1).find("distance"), std::string::npos);
}

TEST(Registration, OrthonormalizedIsARotation) {
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  R(0, 1) += 1e-3;
  R(2, 2) -= 2e-3;
  const Eigen::Matrix3d Q = orthonormalized(R);
  EXPECT_LT((Q.transpose() * Q - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
  EXPECT_LT((Q - R).norm(), 5e-3);
}

}  // namespace
