// Renders known scenes off-screen and checks the picture where things must project:
// red where the CAD model at the estimated pose is, green where its template is
// (paper Fig. 9), faint grey truth, orange contour, blue plan, the nozzle, the cloud.
// The expected pixels come from a pinhole model of the camera set-up written out here,
// independently of VTK. Needs no display: starts a private Xvfb when there is none.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "depowder/progress_t.hpp"
#include "depowder/viewer/display.hpp"
#include "depowder/viewer/renderer.hpp"
#include "depowder/waypoint_t.hpp"
#include "picture_checks.hpp"

using namespace depowder;
using namespace depowder::viewer;
using namespace depowder::viewer::test;

namespace {

std::unique_ptr<Xvfb> g_xvfb;

class Render : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!displayUsable()) g_xvfb = std::make_unique<Xvfb>(1024, 768);
  }
  static void TearDownTestSuite() { g_xvfb.reset(); }
};

constexpr double kSide = 0.08;  // m

/// The known scene: a cube part estimated at T_est with a template on its top face.
Scene knownScene() {
  Scene s;
  s.box_size = Eigen::Vector3d(0.40, 0.30, 0.20);
  PartScene& p = s.part("cube");
  p.mesh = std::make_shared<const Mesh>(cubeMesh(kSide));
  p.has_estimate = true;
  p.T_cell_part = makePoseRpy({-0.06, 0.0, 0.06}, 0, 0, 0.3);
  p.track_status = 1;
  p.method = "cu";
  p.template_version = 1;
  for (int i = -5; i <= 5; ++i)  // top face, 6 mm grid (Alg. 2 keeps what the cameras see)
    for (int j = -5; j <= 5; ++j) p.template_points.emplace_back(0.006 * i, 0.006 * j, kSide / 2);
  p.has_truth = true;
  p.T_cell_part_true = makePoseRpy({0.10, 0.03, 0.06}, 0, 0, -0.2);
  p.has_progress = true;
  p.phase = progress_t::PHASE_VACUUM_TRACKED;
  p.eta = 0.42;
  const Eigen::Vector3d c = p.T_cell_part.translation();
  for (const auto& [dx, dy] : std::vector<std::pair<double, double>>{{-1, -1}, {1, -1}, {1, 1}, {-1, 1}})
    p.contour.push_back(c + Eigen::Vector3d(0.07 * dx, 0.07 * dy, -0.03));
  s.plan = {{0.15, -0.10, 0.15}, {0.15, 0.10, 0.15}};
  s.plan_id = 3;
  s.has_nozzle = true;
  s.T_cell_nozzle = makePoseRpy({0.10, -0.09, 0.18}, M_PI, 0, 0);  // spraying straight down
  s.tool = waypoint_t::TOOL_VACUUM;
  for (double x = -0.19; x <= 0.19; x += 0.01)  // powder surface, away from the parts
    for (double y = -0.14; y <= 0.14; y += 0.01)
      if (std::abs(x + 0.06) > 0.08 && std::abs(x - 0.10) > 0.08) s.cloud.emplace_back(x, y, 0.015);
  s.cloud_seq = 12;
  ++s.versions.cloud;
  return s;
}

RenderOptions options(const Scene& s, int w, int h) {
  RenderOptions o;
  o.width = w;
  o.height = h;
  o.offscreen = true;
  o.camera = defaultCamera(s.box_size);
  return o;
}

}  // namespace

TEST_F(Render, KnownSceneProjectsWhereThePinholeModelSays) {
  const Scene s = knownScene();
  const RenderOptions o = options(s, 640, 480);
  Renderer r(o);
  r.update(s);
  const Image img = r.capture();
  // To look at it: DEPOWDER_VIEWER_KEEP=DIR keeps the picture.
  if (const char* keep = std::getenv("DEPOWDER_VIEWER_KEEP")) r.savePng(std::string(keep) + "/known_scene.png");
  ASSERT_EQ(img.width, 640);
  ASSERT_EQ(img.height, 480);
  ASSERT_EQ(img.rgb.size(), 640u * 480u * 3u);
  auto px = [&](const Eigen::Vector3d& p) { return project(o.camera, img.width, img.height, p); };
  const PartScene& part = s.parts[0];

  // Green where the template projects (on top of the red model: the points win).
  for (const Eigen::Vector3d& t : {Eigen::Vector3d(0, 0, kSide / 2), Eigen::Vector3d(0.024, -0.024, kSide / 2),
                                   Eigen::Vector3d(-0.03, 0.03, kSide / 2)}) {
    const Eigen::Vector2d uv = px(part.T_cell_part * t);
    EXPECT_TRUE(anyNear(img, uv, 1, isGreen)) << "template point at pixel " << uv.transpose();
  }
  // Red where the model's front faces project and no template point is.
  for (const Eigen::Vector3d& f : {Eigen::Vector3d(0, -kSide / 2, 0), Eigen::Vector3d(0.02, -kSide / 2, -0.02),
                                   Eigen::Vector3d(-kSide / 2, 0, 0)}) {
    const Eigen::Vector2d uv = px(part.T_cell_part * f);
    const std::uint8_t* c = img.at(static_cast<int>(uv.x()), static_cast<int>(uv.y()));
    EXPECT_TRUE(isRed(c)) << "model face at pixel " << uv.transpose() << " is " << int(c[0]) << "," << int(c[1]) << ","
                          << int(c[2]);
  }
  // Truth: faint grey, never red or green.
  const Eigen::Vector2d truth_uv = px(part.T_cell_part_true * Eigen::Vector3d(0, -kSide / 2, 0));
  const std::uint8_t* t = img.at(static_cast<int>(truth_uv.x()), static_cast<int>(truth_uv.y()));
  EXPECT_TRUE(isGrey(t, 40) && t[0] < 140) << int(t[0]) << "," << int(t[1]) << "," << int(t[2]);
  // Powder contour (front edge, in front of the part), nozzle plan, nozzle body, cloud.
  const Eigen::Vector3d front = 0.5 * (part.contour[0] + part.contour[1]);
  EXPECT_TRUE(anyNear(img, px(front), 2, isOrange));
  EXPECT_TRUE(anyNear(img, px(0.5 * (s.plan[0] + s.plan[1])), 2, isBlue));
  EXPECT_TRUE(anyNear(img, px(s.T_cell_nozzle * Eigen::Vector3d(0, 0, -0.03)), 1, isCyan));
  EXPECT_TRUE(anyNear(img, px({-0.19, -0.14, 0.015}), 1, [](const std::uint8_t* c) { return isGrey(c, 80); }));

  // Red and green stay near the part: nothing red or green far from its projection.
  const Eigen::Vector2d centre = px(part.T_cell_part.translation());
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u)
      if ((Eigen::Vector2d(u, v) - centre).norm() > 80) {
        ASSERT_FALSE(isRed(img.at(u, v))) << "red at " << u << "," << v;
        ASSERT_FALSE(isGreen(img.at(u, v))) << "green at " << u << "," << v;
      }
}

// The cell's tool replaces the small marker: a tube 2.5 cm round and 12 cm long shows cyan
// 10 cm above the tip, where the 6 cm marker did not reach.
TEST_F(Render, TheCellsToolIsDrawnAtTheNozzle) {
  Scene s = knownScene();
  const RenderOptions o = options(s, 640, 480);
  auto px = [&](const Eigen::Vector3d& p) { return project(o.camera, o.width, o.height, p); };
  const Eigen::Vector2d up_the_tube = px(s.T_cell_nozzle * Eigen::Vector3d(0, 0, -0.10));
  Renderer marker(o);
  marker.update(s);
  EXPECT_FALSE(anyNear(marker.capture(), up_the_tube, 0, isCyan));
  s.tool_mesh = std::make_shared<const Mesh>(cylinderMesh(0.0125, 0.12, 16));
  Renderer tool(o);
  tool.update(s);
  EXPECT_TRUE(anyNear(tool.capture(), up_the_tube, 1, isCyan));
}

TEST_F(Render, NothingRedOrGreenBeforeTheTrackerSpeaks) {
  Scene s = knownScene();
  s.parts[0].has_estimate = false;
  Renderer r(options(s, 320, 240));
  r.update(s);
  const Image before = r.capture();
  EXPECT_EQ(count(before, isRed), 0);
  EXPECT_EQ(count(before, isGreen), 0);

  // The same renderer follows the scene: the estimate appears, then moves.
  s.parts[0].has_estimate = true;
  ++s.versions.parts;
  r.update(s);
  const Image after = r.capture();
  EXPECT_GT(count(after, isRed), 150);
  EXPECT_GT(count(after, isGreen), 30);
  const RenderOptions o = options(s, 320, 240);
  const Eigen::Vector2d old_uv = project(o.camera, 320, 240, s.parts[0].T_cell_part * Eigen::Vector3d(0, -0.04, 0));
  s.parts[0].T_cell_part.translation().y() += 0.12;
  ++s.versions.parts;
  r.update(s);
  const Image moved = r.capture();
  EXPECT_FALSE(isRed(moved.at(static_cast<int>(old_uv.x()), static_cast<int>(old_uv.y()))));
  const Eigen::Vector2d new_uv = project(o.camera, 320, 240, s.parts[0].T_cell_part * Eigen::Vector3d(0, -0.04, 0));
  EXPECT_TRUE(isRed(moved.at(static_cast<int>(new_uv.x()), static_cast<int>(new_uv.y()))));
}

TEST_F(Render, PngHasTheRequestedSizeAndTheRenderedPixels) {
  const Scene s = knownScene();
  Renderer r(options(s, 333, 251));  // odd sizes catch row-stride mistakes
  r.update(s);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "depowder_viewer_png" / "nested";
  std::filesystem::remove_all(dir.parent_path());
  const std::string path = (dir / "scene.png").string();
  r.savePng(path);  // creates the directories
  ASSERT_TRUE(std::filesystem::exists(path));
  EXPECT_GT(std::filesystem::file_size(path), 1000u);
  const Image png = readPng(path);
  EXPECT_EQ(png.width, 333);
  EXPECT_EQ(png.height, 251);
  const Image direct = r.capture();
  EXPECT_EQ(png.rgb, direct.rgb);
  EXPECT_GT(count(png, isRed), 50);
  EXPECT_GT(count(png, isGreen), 10);
  std::filesystem::remove_all(dir.parent_path());
  EXPECT_THROW(readPng(path), RenderError);
}

TEST_F(Render, NoDisplayIsAnErrorNotACrash) {
  const std::string saved = std::getenv("DISPLAY") ? std::getenv("DISPLAY") : "";
  setenv("DISPLAY", ":4093", 1);  // no server there
  EXPECT_FALSE(displayUsable());
  EXPECT_THROW(Renderer(options(knownScene(), 64, 64)), RenderError);
  unsetenv("DISPLAY");
  EXPECT_THROW(Renderer(options(knownScene(), 64, 64)), RenderError);
  setenv("DISPLAY", saved.c_str(), 1);
  EXPECT_TRUE(displayUsable());
}
