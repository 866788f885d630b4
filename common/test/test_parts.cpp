// The default cell's parts: size, frame, closed outward-wound shells, the committed STLs, and
// depowder-make-parts --check on a part and on a broken one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/child_process.hpp"
#include "depowder/mesh.hpp"
#include "depowder/parts.hpp"

namespace {

using depowder::Mesh;
using depowder::welded;

// Connected components of the welded mesh (shells), as lists of triangle indices.
std::vector<std::vector<std::size_t>> shells(const Mesh& mesh) {
  std::vector<int> parent(mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto& t : mesh.triangles) {
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  std::map<int, std::vector<std::size_t>> byRoot;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) byRoot[find(mesh.triangles[i][0])].push_back(i);
  std::vector<std::vector<std::size_t>> out;
  for (auto& [root, tris] : byRoot) out.push_back(std::move(tris));
  return out;
}

class PartTest : public ::testing::TestWithParam<std::string> {
 protected:
  Mesh part() const { return depowder::parts::byName(GetParam()); }
};

TEST_P(PartTest, DiagonalIsEightToFifteenCentimetres) {
  const double diagonal = depowder::bounds(part()).sizes().norm();
  EXPECT_GE(diagonal, 0.08);
  EXPECT_LE(diagonal, 0.15);
}

TEST_P(PartTest, BoundingBoxIsCentredAtOrigin) {
  const Eigen::Vector3d centre = depowder::bounds(part()).center();
  EXPECT_LT(centre.cwiseAbs().maxCoeff(), 1e-9) << centre.transpose();
}

TEST_P(PartTest, VolumeIsPositiveAndSmallerThanBoundingBox) {
  const Mesh mesh = part();
  const double volume = depowder::volume(mesh);
  EXPECT_GT(volume, 0.0);
  EXPECT_LE(volume, depowder::bounds(mesh).volume() * (1 + 1e-9));  // equal for the cube
}

// Closed, manifold along its edges and wound alike: each edge in one triangle each way round.
TEST_P(PartTest, EveryEdgeIsSharedByTwoOppositelyWoundTriangles) {
  EXPECT_EQ(depowder::closednessProblem(welded(part()), true), "");
}

TEST_P(PartTest, EveryShellIsWoundOutward) {
  const Mesh mesh = welded(part());
  const auto components = shells(mesh);
  ASSERT_FALSE(components.empty());
  for (std::size_t s = 0; s < components.size(); ++s) {
    Mesh shell = mesh;
    shell.triangles.clear();
    for (std::size_t i : components[s]) shell.triangles.push_back(mesh.triangles[i]);
    EXPECT_GT(depowder::volume(shell), 0.0) << "shell " << s << " of " << components.size();
  }
}

TEST_P(PartTest, TriangleCountIsReasonable) {
  const std::size_t n = part().triangles.size();
  EXPECT_GE(n, 12u);
  EXPECT_LE(n, 4000u);  // keeps each binary STL under about 200 KB
}

TEST_P(PartTest, CommittedStlMatchesGenerator) {
  const Mesh generated = part();
  const std::string path = std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/" + GetParam() + ".stl";
  const Mesh loaded = depowder::loadMesh(path);
  ASSERT_EQ(loaded.triangles.size(), generated.triangles.size())
      << path << " is stale: regenerate with depowder-make-parts config/parts";
  const auto a = depowder::bounds(loaded), b = depowder::bounds(generated);
  EXPECT_LT((a.min() - b.min()).cwiseAbs().maxCoeff(), 1e-6) << path;
  EXPECT_LT((a.max() - b.max()).cwiseAbs().maxCoeff(), 1e-6) << path;
  EXPECT_EQ(depowder::closednessProblem(welded(loaded), true), "") << path;
}

INSTANTIATE_TEST_SUITE_P(DefaultParts, PartTest, ::testing::ValuesIn(depowder::parts::names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

TEST(Parts, NamesAreTheFiveDefaultParts) {
  EXPECT_EQ(depowder::parts::names(), (std::vector<std::string>{"cube", "cup", "propeller", "owl", "pipe"}));
}

TEST(Parts, UnknownNameThrowsNamingTheKnownParts) {
  try {
    depowder::parts::byName("teapot");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("teapot"), std::string::npos) << what;
    for (const auto& name : depowder::parts::names()) EXPECT_NE(what.find(name), std::string::npos) << what;
  }
}

}  // namespace

// depowder-make-parts --check: a committed part bounds a solid (exit 0); the same part less one
// triangle is refused with the edge that lost its neighbour (exit 1), and a missing file by name.
TEST(MakeParts, CheckSaysWhetherTheSimulatorTakesAMesh) {
  const std::string tool = std::string(DEPOWDER_BIN_DIR) + "/depowder-make-parts --check ";
  const std::string out = ::testing::TempDir() + "make_parts_check.txt";
  auto run = [&](const std::string& args) {
    const int status = depowder::testutil::shellExitStatus(tool + args + " > " + out + " 2>&1");
    std::ifstream in(out);
    return std::pair{status, std::string(std::istreambuf_iterator<char>(in), {})};
  };
  const std::string cube = std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/cube.stl";
  const auto [ok, said] = run(cube);
  EXPECT_EQ(ok, 0) << said;
  EXPECT_NE(said.find("bounds a solid"), std::string::npos) << said;

  Mesh open = depowder::loadMesh(cube);
  open.triangles.pop_back();
  const std::string open_path = ::testing::TempDir() + "open_cube.stl";
  depowder::saveStl(open, open_path);
  const auto [refused, why] = run(cube + " " + open_path + " " + ::testing::TempDir() + "missing.stl");
  EXPECT_EQ(refused, 1) << why;
  EXPECT_NE(why.find("is in 1 triangle(s) one way round and 0 the other"), std::string::npos) << why;
  EXPECT_NE(why.find("missing.stl': cannot open file"), std::string::npos) << why;
}
