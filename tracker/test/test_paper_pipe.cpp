// The paper's own pipe: the authors' P_cad (../shared/data/parts/paper_pipe_cm.xyz, 11,650
// surface points of a bent hollow tube, cm), half buried in a flat powder bed and seen by one
// camera above, at a known pose. From a guess 3 deg / 4 mm off, ICP on the template of Alg. 2
// (the CAD points within xi of the scan at the guess) must land near the true pose. The whole
// CAD model (Vanilla's) is registered too and printed beside it: in one such registration it
// lands within 0.12 deg of the template's, since the matches' normal test and the robust
// kernel keep its buried half off the powder (Table I's Vanilla rows, docs/results.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>

#include "depowder/files.hpp"
#include "depowder/tracker/registration.hpp"
#include "depowder/tracker/template.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

// The paper's xi for the pipe (Sec. V-A) and the tracker's voxel and normal sizes.
constexpr double kXi = 0.008, kLeaf = 0.005, kNormalRadius = 0.01;

// What a camera at `eye` sees of the pipe at T_cell_part above a powder bed at height
// `powder_z`: per 3 mrad pixel the nearest of the part's points above the powder and a 4 mm
// grid of powder points, with 0.5 mm range noise (seeded), thinned to one point per 5 mm voxel as
// the camera proxy does.
Cloud cameraView(const Cloud& cad, const Pose& T_cell_part, const Point& eye, double powder_z) {
  Cloud candidates;
  for (const Point& p : cad)
    if (const Point q = T_cell_part * p; q.z() > powder_z) candidates.push_back(q);
  for (double x = -0.12; x <= 0.12; x += 0.004)
    for (double y = -0.12; y <= 0.12; y += 0.004) candidates.emplace_back(x, y, powder_z);
  constexpr double kPixel = 0.003;  // rad
  std::map<std::pair<long, long>, Point> nearest;
  for (const Point& q : candidates) {
    const Eigen::Vector3d d = q - eye;
    const std::pair<long, long> pixel{std::lround(std::atan2(d.x(), -d.z()) / kPixel),
                                      std::lround(std::atan2(d.y(), -d.z()) / kPixel)};
    auto [it, fresh] = nearest.try_emplace(pixel, q);
    if (!fresh && (q - eye).squaredNorm() < (it->second - eye).squaredNorm()) it->second = q;
  }
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.0005);
  Cloud seen;
  for (const auto& [pixel, q] : nearest) seen.push_back(q + noise(rng) * (q - eye).normalized());
  return gather(seen, thinned(seen, allIndices(seen.size()), kLeaf));
}

class PaperPipe : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string path = std::string(DEPOWDER_SHARED_DATA) + "/parts/paper_pipe_cm.xyz";
    if (!std::ifstream(path)) GTEST_SKIP() << "the paper's pipe not found at " << path << " (not part of the project)";
    cad_ = readXyz(path, 0.01);  // cm -> m
    ASSERT_EQ(cad_.size(), 11650u);
  }

  // Registers `model_indices` of P_cad (thinned to kLeaf, normals turned to the camera) onto
  // the scan from `guess`; returns the rotation (deg) and translation (mm) error.
  std::pair<double, double> error(const Indices& model_indices, const Cloud& scan, const Point& eye, const Pose& guess,
                                  const Pose& truth) const {
    const Cloud model = gather(cad_, thinned(cad_, model_indices, kLeaf));
    // The CAD points carry no normals: estimated from P_cad itself, each turned to face the camera
    // (in the part frame at the guess), as the scan's are.
    const ScanIndex cad_index(cad_, 2 * kNormalRadius);
    const Cloud cad_normals = scanNormals(cad_index, {guess.inverse(Eigen::Isometry) * eye}, kNormalRadius);
    const ScanIndex model_index(model, 2 * kXi);
    const Cloud model_normals = gather(cad_normals, thinned(cad_, model_indices, kLeaf));
    const ScanIndex scan_index(scan, 2 * kXi);
    const Cloud scan_normals = scanNormals(scan_index, {eye}, kNormalRadius);
    IcpConfig config;
    config.max_iterations = 60;
    const RegistrationResult r =
        registerSurfaces({model, model_normals, model_index}, {scan, scan_normals, scan_index}, guess, kXi, config);
    EXPECT_TRUE(r.ok()) << r.reason;
    return {rotationAngle(r.T_target_source.linear(), truth.linear()) * 180 / M_PI,
            translationDistance(r.T_target_source, truth) * 1000};
  }

  Cloud cad_;
};

// Table I's setting on the authors' model: at 30, 50 and 70 % of P_cad above the powder and three
// headings each, the template's fit lands within 1.5 deg and 1 mm (measured: at most 1.30 deg
// and 0.74 mm).
TEST_F(PaperPipe, TemplateOfAlg2LandsNearTheTruth) {
  const Point eye(0.15, -0.1, 0.6);
  double worst_rot = 0, worst_mm = 0;
  for (const double above : {0.3, 0.5, 0.7})
    for (const double yaw : {0.7, 2.4, -1.9}) {
      const Pose truth = makePoseRpy({0.01, -0.02, 0.045}, 0.2, -0.1, yaw);
      // The powder at the height that leaves `above` of P_cad above it.
      std::vector<double> heights;
      for (const Point& p : cad_) heights.push_back((truth * p).z());
      const auto at = heights.begin() + static_cast<long>((1 - above) * static_cast<double>(heights.size()));
      std::nth_element(heights.begin(), at, heights.end());
      const Cloud scan = cameraView(cad_, truth, eye, *at);
      const Pose guess = truth * makePoseRpy({0.003, -0.002, 0.0015}, 0.03, -0.025, 0.03);  // 3.0 deg, 3.9 mm
      const ScanIndex scan_index(scan, 2 * kXi);
      const Indices tmpl = deriveTemplate(cad_, guess, scan_index, kXi);  // Alg. 2 at the guess
      const auto [cu_rot, cu_mm] = error(tmpl, scan, eye, guess, truth);
      const auto [whole_rot, whole_mm] = error(allIndices(cad_.size()), scan, eye, guess, truth);
      std::printf(
          "%2.0f %% above the powder, yaw %4.1f rad: scan %zu points, template %zu of %zu; "
          "template %.2f deg %.2f mm, whole model %.2f deg %.2f mm\n",
          above * 100, yaw, scan.size(), tmpl.size(), cad_.size(), cu_rot, cu_mm, whole_rot, whole_mm);
      EXPECT_LT(cu_rot, 1.5) << above << " above, yaw " << yaw;
      EXPECT_LT(cu_mm, 1.0) << above << " above, yaw " << yaw;
      worst_rot = std::max(worst_rot, cu_rot);
      worst_mm = std::max(worst_mm, cu_mm);
    }
  std::printf("worst: %.2f deg %.2f mm\n", worst_rot, worst_mm);
}

}  // namespace
