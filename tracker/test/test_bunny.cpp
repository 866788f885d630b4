// Real scans: bun0 registered onto bun4 from identity (ground truth: ../shared/data/README.md).
// Our point-to-plane ICP must land within 6 deg / 5 mm of the true transform and at least as
// close as pcl::IterativeClosestPoint run here with the same correspondence distance.
// The only tracker test that includes PCL.
#include <gtest/gtest.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "depowder/tracker/registration.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

struct Pcd {
  Cloud points;
  Cloud normals;  ///< empty if the file has none
};

// A tiny reader for the ASCII PCD files used here (v0.5 and v0.7 headers, fields x y z
// [normal_x normal_y normal_z ...]). Returns false with `why` on anything else.
bool readAsciiPcd(const std::string& path, Pcd& out, std::string& why) {
  std::ifstream in(path);
  if (!in) return why = "cannot open " + path, false;
  std::vector<std::string> fields;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (key == "FIELDS") {
      for (std::string f; ls >> f;) fields.push_back(f);
    } else if (key == "DATA") {
      std::string kind;
      ls >> kind;
      if (kind != "ascii") return why = path + ": DATA " + kind + " is not supported", false;
      break;
    }
  }
  auto col = [&](const std::string& name) {
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (fields[i] == name) return static_cast<int>(i);
    return -1;
  };
  const int x = col("x"), nx = col("normal_x");
  if (x < 0) return why = path + ": no x field", false;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::vector<double> v;
    for (double d; ls >> d;) v.push_back(d);
    if (v.size() < fields.size()) continue;
    out.points.emplace_back(v[x], v[x + 1], v[x + 2]);
    if (nx >= 0) out.normals.emplace_back(Eigen::Vector3d(v[nx], v[nx + 1], v[nx + 2]).normalized());
  }
  return true;
}

// README: rotation of about 34.3 deg taking bun0 onto bun4 (from the Stanford bun.conf).
Pose groundTruth() {
  Eigen::Matrix4d M;
  M << 0.8264, 0.0041, -0.5631, 0.0368,   //
      -0.0106, 0.9999, -0.0082, -0.0003,  //
      0.5631, 0.0128, 0.8263, 0.0383,     //
      0, 0, 0, 1;
  Pose T(M);
  T.linear() = orthonormalized(M.topLeftCorner<3, 3>());
  return T;
}

double rotErrDeg(const Pose& a, const Pose& b) { return rotationAngle(a.linear(), b.linear()) * 180.0 / M_PI; }
double transErrMm(const Pose& a, const Pose& b) { return translationDistance(a, b) * 1000.0; }

Pose pclIcp(const Cloud& source, const Cloud& target, double max_distance) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr src(new pcl::PointCloud<pcl::PointXYZ>), tgt(new pcl::PointCloud<pcl::PointXYZ>);
  for (const Point& p : source) src->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  for (const Point& p : target) tgt->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(src);
  icp.setInputTarget(tgt);
  icp.setMaxCorrespondenceDistance(max_distance);
  icp.setMaximumIterations(100);
  icp.setTransformationEpsilon(1e-10);
  icp.setEuclideanFitnessEpsilon(1e-8);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  icp.align(aligned);
  Pose T(icp.getFinalTransformation().cast<double>());
  T.linear() = orthonormalized(T.linear());
  return T;
}

class Bunny : public ::testing::TestWithParam<double> {
 protected:
  void SetUp() override {
    const std::string dir = std::string(DEPOWDER_SHARED_DATA) + "/scans/";
    std::string why;
    if (!std::ifstream(dir + "bun0.pcd") || !std::ifstream(dir + "bun4.pcd"))
      GTEST_SKIP() << "reference scans not found in " << dir << " (../shared/data is not part of the project)";
    ASSERT_TRUE(readAsciiPcd(dir + "bun0.pcd", bun0_, why)) << why;
    ASSERT_TRUE(readAsciiPcd(dir + "bun4.pcd", bun4_, why)) << why;
    ASSERT_EQ(bun0_.points.size(), 397u);
    ASSERT_EQ(bun4_.points.size(), 361u);
    ASSERT_EQ(bun0_.normals.size(), bun0_.points.size());
  }
  Pcd bun0_, bun4_;
};

TEST_P(Bunny, Bun0OntoBun4FromIdentityBeatsPcl) {
  const double d = GetParam();
  // A one-off registration from identity, 24 mm mean nearest-neighbour distance: no prior,
  // tight convergence, and a kernel scale (1 cm) that does not refuse the initially distant
  // matches (the tracker's 2 mm suits its per-frame motions, not this). bun4's normals are
  // estimated and turned towards its scanner (the PCD's viewpoint, the origin), as bun0's are.
  // Against PCL's point-to-point ICP, the same metric (tangent_weight 1); the tracker's default
  // weight (0.3) lands 0.44-0.60 deg and 1.0-1.2 mm off (measured).
  IcpConfig config;
  config.tangent_weight = 1;
  config.max_iterations = 100;
  config.kernel_scale = 0.01;
  config.convergence_translation = 1e-6;
  config.convergence_rotation = 1e-5;
  const ScanIndex bun4_index(bun4_.points, 0.01);
  const Cloud bun4_normals = scanNormals(bun4_index, {Point::Zero()}, config.normal_radius);
  const RegistrationResult ours =
      registerSurfaces(bun0_.points, bun0_.normals, bun4_.points, bun4_normals, Pose::Identity(), d, config);
  ASSERT_TRUE(ours.ok()) << ours.reason;
  const Pose truth = groundTruth();
  const Pose pcl = pclIcp(bun0_.points, bun4_.points, d);
  const double ours_rot = rotErrDeg(ours.T_target_source, truth), ours_t = transErrMm(ours.T_target_source, truth);
  const double pcl_rot = rotErrDeg(pcl, truth), pcl_t = transErrMm(pcl, truth);
  std::printf("d = %.0f mm: ours %.2f deg %.2f mm (%d it), pcl point-to-point %.2f deg %.2f mm\n", d * 1000, ours_rot,
              ours_t, ours.iterations, pcl_rot, pcl_t);
  EXPECT_LT(ours_rot, 6.0);
  EXPECT_LT(ours_t, 5.0);
  EXPECT_LE(ours_rot, pcl_rot);
  EXPECT_LE(ours_t, pcl_t);
}

INSTANTIATE_TEST_SUITE_P(CorrespondenceDistance, Bunny, ::testing::Values(0.02, 0.05, 0.1));

}  // namespace
