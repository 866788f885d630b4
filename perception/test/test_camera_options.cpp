// depowder-camera's configuration: the default cell's perception section, the files
// section, the command line, errors naming the key, and the LCM URL it opens.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "camera_options.hpp"
#include "depth_msg.hpp"

using namespace depowder;
using namespace depowder::perception;
namespace fs = std::filesystem;

namespace {

std::optional<CameraNodeOptions> parse(std::vector<std::string> args) {
  args.insert(args.begin(), "depowder-camera");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return parseOptions(static_cast<int>(argv.size()), argv.data());
}

// A cell file in a fresh temp directory holding `perception_section`.
std::string cellWith(const std::string& sections) {
  const fs::path dir = fs::temp_directory_path() / ("depowder_options_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "cell.yaml").string();
  std::ofstream(path) << "box: {size: [0.4, 0.3, 0.2]}\n" << sections;
  return path;
}

std::string errorOf(const std::vector<std::string>& args) {
  try {
    parse(args);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(CameraOptions, DefaultCellStatesTheLibraryDefaults) {
  const auto o = parse({"--cell", std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml"});
  ASSERT_TRUE(o);
  const PerceptionConfig d;
  EXPECT_EQ(o->perception.crop_margin, d.crop_margin);
  EXPECT_EQ(o->perception.voxel_leaf, d.voxel_leaf);
  EXPECT_EQ(o->perception.outlier_min_neighbours, d.outlier_min_neighbours);
  EXPECT_EQ(o->perception.resolution, d.resolution);
  EXPECT_EQ(o->perception.merger.match_tolerance, d.merger.match_tolerance);
  EXPECT_EQ(o->perception.merger.max_wait, d.merger.max_wait);
  EXPECT_EQ(o->perception.merger.silent_after, d.merger.silent_after);
  EXPECT_EQ(o->perception.merger.stale_after, d.merger.stale_after);
  EXPECT_EQ(o->input, "DEPTH_.*");
  EXPECT_EQ(o->output, "POINTS");
  EXPECT_EQ(o->recv_buf_size, 4194304);
  EXPECT_TRUE(o->files.dir.empty());  // live by default
  EXPECT_EQ(o->cell.cameras.size(), 2u);
  // The self-filter: the library's defaults (the default cell's 25 cm tube and the authors' end
  // effector, taken from its planner and robot sections).
  const SelfFilterConfig& sf = o->perception.self_filter;
  EXPECT_DOUBLE_EQ(sf.radius, d.self_filter.radius);
  EXPECT_NEAR(sf.length, d.self_filter.length, 1e-12);
  ASSERT_EQ(sf.effector.size(), d.self_filter.effector.size());
  for (std::size_t k = 0; k < sf.effector.size(); ++k) {
    EXPECT_EQ(sf.effector[k].radius, d.self_filter.effector[k].radius);
    EXPECT_EQ(sf.effector[k].length, d.self_filter.effector[k].length);
  }
  EXPECT_TRUE(sf.T_flange_nozzle.isApprox(d.self_filter.T_flange_nozzle, 1e-12));
}

// The self-filter takes the cell's tool (the planner's nozzle radius, the robot's tool offset and
// end effector), so that a cell describes its tool once; perception.self_filter's own keys, if
// given, are used instead.
TEST(CameraOptions, SelfFilterTakesTheCellsTool) {
  const std::string tool =
      "robot: {tool_offset: {xyz: [0, 0.1, 0.3], rpy_deg: [20, 0, 0]}, effector: [{radius: 0.03, length: 0.1}]}\n"
      "planner: {nozzle: {radius: 0.02}}\n";
  auto o = parse({"--cell", cellWith(tool)});
  ASSERT_TRUE(o);
  const SelfFilterConfig& sf = o->perception.self_filter;
  EXPECT_DOUBLE_EQ(sf.radius, 0.02);
  EXPECT_DOUBLE_EQ(sf.length, std::hypot(0.1, 0.3));  // up to the flange, as the planner grows it
  EXPECT_TRUE(sf.T_flange_nozzle.isApprox(makePoseRpy({0, 0.1, 0.3}, 20 * M_PI / 180, 0, 0), 1e-12));
  ASSERT_EQ(sf.effector.size(), 1u);
  EXPECT_EQ(sf.effector[0].radius, 0.03);
  EXPECT_EQ(sf.effector[0].length, 0.1);
  o = parse({"--cell", cellWith(tool + "perception: {self_filter: {radius: 0.01, length: 0.2, effector: []}}\n")});
  ASSERT_TRUE(o);
  EXPECT_DOUBLE_EQ(o->perception.self_filter.radius, 0.01);
  EXPECT_DOUBLE_EQ(o->perception.self_filter.length, 0.2);
  EXPECT_TRUE(o->perception.self_filter.effector.empty());
}

TEST(CameraOptions, FilesSectionAndCommandLine) {
  const std::string cell = cellWith(
      "perception:\n  voxel_leaf: 0.003\n  files:\n    dir: scans\n    rate_hz: 5\n    camera: SCANNER\n"
      "    pose: {xyz: [0.1, 0.2, 0.3], rpy_deg: [0, 0, 90]}\n    max_range: 2.5\n");
  auto o = parse({"--cell", cell});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->perception.voxel_leaf, 0.003);
  EXPECT_EQ(o->files.dir, (fs::path(cell).parent_path() / "scans").string());  // relative to the YAML
  EXPECT_EQ(o->files.rate_hz, 5);
  EXPECT_EQ(o->files.camera.name, "SCANNER");
  EXPECT_EQ(o->files.camera.max_range, 2.5);
  EXPECT_TRUE(o->files.camera.T_cell_camera.translation().isApprox(Eigen::Vector3d(0.1, 0.2, 0.3)));
  EXPECT_TRUE((o->files.camera.T_cell_camera.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY()));
  // The command line wins.
  o = parse({"--cell", cell, "--files", "/data/run1", "--rate", "12.5", "--camera-pose", "1,2,3,0,90,0", "--loop",
             "--prefix", "A_", "--url", "memq://"});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->files.dir, "/data/run1");
  EXPECT_EQ(o->files.rate_hz, 12.5);
  EXPECT_TRUE(o->files.loop);
  EXPECT_EQ(o->cell.lcm.prefix, "A_");
  EXPECT_EQ(o->cell.lcm.url, "memq://");
  EXPECT_TRUE(o->files.camera.T_cell_camera.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE((o->files.camera.T_cell_camera.linear() * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_FALSE(parse({"--cell", cell, "--help"}));
}

TEST(CameraOptions, ErrorsNameTheKeyOrFlag) {
  EXPECT_NE(errorOf({"--cell", cellWith("perception: {voxel_size: 0.005}\n")}).find("unknown key 'voxel_size'"),
            std::string::npos);
  const std::string leaf = errorOf({"--cell", cellWith("perception: {voxel_leaf: 0.5}\n")});
  EXPECT_NE(leaf.find("perception.voxel_leaf"), std::string::npos) << leaf;
  EXPECT_NE(leaf.find("[0.001, 0.05]"), std::string::npos) << leaf;
  EXPECT_NE(errorOf({"--cell", cellWith("perception: {files: {rate: 3}}\n")}).find("unknown key 'rate'"),
            std::string::npos);
  const std::string effector =
      errorOf({"--cell", cellWith("perception: {self_filter: {effector: [{radius: 0.03, length: 0}]}}\n")});
  EXPECT_NE(effector.find("perception.self_filter.effector[0].length"), std::string::npos) << effector;
  const std::string cell = cellWith("perception: {}\n");
  EXPECT_NE(errorOf({"--cell", cell, "--rate", "fast"}).find("--rate wants a number"), std::string::npos);
  EXPECT_NE(errorOf({"--cell", cell, "--camera-pose", "1,2,3"}).find("--camera-pose wants x,y,z,roll,pitch,yaw"),
            std::string::npos);
  EXPECT_NE(errorOf({"--cell", cell, "--frobnicate"}).find("unknown option '--frobnicate'"), std::string::npos);
  EXPECT_NE(errorOf({"--cell", cell, "--files"}).find("--files needs a value"), std::string::npos);
}

TEST(CameraOptions, LcmUrlGetsALargeReceiveBuffer) {
  ::unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(lcmUrl("", 4194304), "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(lcmUrl("udpm://239.255.76.67:7667", 1000), "udpm://239.255.76.67:7667?recv_buf_size=1000");
  EXPECT_EQ(lcmUrl("udpm://239.255.76.67:7667?recv_buf_size=5", 1000), "udpm://239.255.76.67:7667?recv_buf_size=5");
  EXPECT_EQ(lcmUrl("memq://", 1000), "memq://");
  EXPECT_EQ(lcmUrl("", 0), "udpm://239.255.76.67:7667?ttl=0");
  ::setenv("LCM_DEFAULT_URL", "udpm://239.255.76.67:7668?ttl=1", 1);
  EXPECT_EQ(lcmUrl("", 64), "udpm://239.255.76.67:7668?ttl=1&recv_buf_size=64");
  ::unsetenv("LCM_DEFAULT_URL");
}

TEST(DepthMsg, RoundTripAndOddByteCount) {
  PinholeCamera cam;
  cam.name = "LEFT";
  cam.width = 3;
  cam.height = 2;
  cam.fx = 100;
  cam.fy = 110;
  cam.cx = 1;
  cam.cy = 0.5;
  cam.min_range = 0.25;
  cam.max_range = 9;
  cam.T_cell_camera = makePoseRpy({0.1, -0.2, 0.5}, 0.3, -0.2, 1.0);
  DepthImage im;
  im.utime = 123456789;
  im.frame = 42;
  im.width = 3;
  im.height = 2;
  im.depth_unit = 0.00025;
  im.depth = {0, 1, 2, 65535, 4000, 7};
  depth_image_t msg = toMsg(im, cam);
  EXPECT_EQ(msg.num_bytes, 12);
  EXPECT_EQ(msg.data[6], 0xff);  // little-endian 65535 at pixel 3
  DepthImage back;
  PinholeCamera cam2;
  ASSERT_TRUE(fromMsg(msg, back, cam2).ok());
  EXPECT_EQ(back.depth, im.depth);
  EXPECT_EQ(back.utime, im.utime);
  EXPECT_EQ(back.frame, 42);
  EXPECT_EQ(cam2.name, "LEFT");
  EXPECT_EQ(cam2.fy, 110);
  EXPECT_FLOAT_EQ(static_cast<float>(back.depth_unit), 0.00025f);
  EXPECT_TRUE(cam2.T_cell_camera.isApprox(cam.T_cell_camera, 1e-12));
  msg.data.pop_back();
  msg.num_bytes = 11;
  EXPECT_EQ(fromMsg(msg, back, cam2).status, FrameStatus::kSizeMismatch);
  msg = toMsg(im, cam);
  msg.T_cell_camera.orientation[0] = 2;  // not a unit quaternion
  const FrameError e = fromMsg(msg, back, cam2);
  EXPECT_EQ(e.status, FrameStatus::kBadHeader);
  EXPECT_NE(e.message.find("quaternion"), std::string::npos) << e.message;
}
