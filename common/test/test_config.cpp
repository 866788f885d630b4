#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>

#include "depowder/node/cell.hpp"

using namespace depowder::node;

namespace {
// Expects a ConfigError whose message contains every one of `parts`.
void expectError(const std::string& yaml, const std::vector<std::string>& parts) {
  try {
    loadCellFromString(yaml, "bad.yaml");
    ADD_FAILURE() << "accepted:\n" << yaml;
  } catch (const ConfigError& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << " lacks " << p;
  }
}
}  // namespace

TEST(Config, DefaultCellLoads) {
  const CellConfig cell = loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml");
  EXPECT_EQ(cell.cameras.size(), 2u);
  ASSERT_GE(cell.parts.size(), 1u);
  for (const auto& p : cell.parts) EXPECT_NE(p.mesh.find("config/parts/"), std::string::npos) << p.mesh;
  // L515: 70 x 55 deg.
  EXPECT_NEAR(cell.cameras[0].fx(), 0.5 * 320 / std::tan(35 * M_PI / 180), 1e-9);
  // Cameras look at the box: the optical axis points down into it.
  EXPECT_LT((cell.cameras[0].T_cell_camera.linear() * Eigen::Vector3d::UnitZ()).z(), -0.5);
}

TEST(Config, LookAtPointsTheOpticalAxis) {
  const auto T = lookAt({0, -1, 1}, {0, 0, 0});
  EXPECT_TRUE((T.linear() * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d(0, 1, -1).normalized()));
  EXPECT_TRUE(depowder::isValidPose(T));
  EXPECT_LT((T.linear() * Eigen::Vector3d::UnitY()).z(), 0);  // image y points down in the world
}

TEST(Config, BadKeysAndValuesNameFileKeyAndRange) {
  expectError("tracker: {}\nbogus: 1\n", {"bad.yaml", "unknown key 'bogus'"});
  expectError("tracker: {}\n? [a, b]\n: 1\n", {"unknown key '(a list or map as a key, line 2)'"});
  expectError("box: {size: [0.4, 0.3], wall: 0.01}\n", {"bad.yaml", "'box.size'", "3 numbers"});
  expectError("box: {size: [0.4, 0.3, -1]}\n", {"'box.size'", "(0, 5]"});
  expectError("box: {wall: 0.5}\n", {"'box.wall'", "out of range", "[0, 0.2]"});
  expectError("box: {wall: thick}\n", {"'box.wall'", "a number"});
  // NaN compares false with both ends of a range, so it once passed every range check.
  expectError("box: {wall: .nan}\n", {"'box.wall'", "value nan is out of range", "[0, 0.2]"});
  expectError("parts:\n  - {name: p, mesh: a.stl, mesh_scale: .nan}\n", {"'parts[0].mesh_scale'", "out of range"});
  expectError("cameras:\n  - {name: A, width: 8}\n", {"'cameras[0].width'", "[16, 4096]"});
  expectError("cameras:\n  - {width: 320}\n", {"'cameras[0].name'", "required"});
  expectError("cameras:\n  - {name: A, pose: {xyz: [0, 0, 1]}, colour: red}\n", {"unknown key 'colour'", "cameras[0]"});
  expectError("cameras:\n  - {name: A, min_range: 2, max_range: 1}\n", {"max_range", "greater than min_range"});
  expectError("cameras:\n  - {name: A, pose: {xyz: [0, 0, 1]}}\n  - {name: A, pose: {xyz: [0, 0, 1]}}\n",
              {"'cameras[1].name'", "used twice"});
  // A name is part of channels, heartbeat figures and the tracker's state file lines.
  expectError("parts:\n  - {name: 'cube 1', mesh: a.stl}\n", {"'parts[0].name'", "'cube 1' must be 1 to 64 letters"});
  expectError("cameras:\n  - {name: ''}\n", {"'cameras[0].name'", "must be 1 to 64"});
  expectError("parts:\n  - {name: p}\n", {"'parts[0].mesh'", "required"});
  expectError("parts:\n  - {name: p, mesh: a.stl, xi: 2}\n", {"'parts[0].xi'", "[0.0005, 0.1]"});
  expectError("parts:\n  - {name: p, mesh: a.stl, initial_pose: {xyz: [0, 0, 0], rpy_deg: [0, 0]}}\n",
              {"'parts[0].initial_pose.rpy_deg'"});
  expectError("parts:\n  - {name: p, mesh: a.stl, initial_pose: {xyz: [0, 0, .nan]}}\n",
              {"'parts[0].initial_pose.xyz'", "finite"});
  expectError("parts:\n  - {name: p, mesh: a.stl, initial_pose: {quat_wxyz: [1, 0, zero, 0]}}\n",
              {"'parts[0].initial_pose.quat_wxyz'", "a number"});
  // look_at alone once put the camera at the cell's origin, looking from there.
  expectError("cameras:\n  - {name: A, look_at: [0, 0, 0.05]}\n", {"'cameras[0].position'", "required with look_at"});
  // Neither pose nor look_at once gave the identity: a camera at the origin looking up.
  expectError("cameras:\n  - {name: A}\n", {"'cameras[0].pose'", "is required, or position and look_at"});
  expectError("cameras:\n  - {name: A, position: [0, 0, 1]}\n", {"'cameras[0].pose'", "is required"});
  expectError("parts: {name: p}\n", {"'parts'", "must be a list"});
  expectError("box: [1, 2\n", {"bad.yaml", "not valid YAML"});
  try {
    loadCell("/nonexistent/cell.yaml");
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/cell.yaml"), std::string::npos);
  }
}

TEST(Config, ModuleSectionsAreLeftToTheirModulesAndChecked) {
  const CellConfig cell = loadCellFromString("tracker: {method: cu, typo: 1}\n");
  const YamlReader tracker = cell.root.child("tracker");
  std::string method;
  tracker.read("method", method);
  EXPECT_EQ(method, "cu");
  try {
    tracker.finish();
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key 'typo' in 'tracker'"), std::string::npos) << e.what();
  }
}

// cell_model (in every process's heartbeat) tells cell files apart by what the processes share:
// box, cameras, parts and each part's mesh by its bytes; not by comments, the file's path or
// a mesh's path, nor by a module's own section.
TEST(Config, CellModelIdFollowsTheSharedSections) {
  char dir_template[] = "/tmp/depowder-cell-XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::filesystem::path dir = dir_template;
  const std::filesystem::path source = std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/cube.stl";
  std::filesystem::create_directories(dir / "a");
  std::filesystem::copy_file(source, dir / "cube.stl");
  std::filesystem::copy_file(source, dir / "a" / "other.stl");
  auto idOf = [&](const std::string& mesh, const std::string& xyz, const std::string& more = "") {
    std::ofstream(dir / "cell.yaml") << "box: {size: [0.4, 0.3, 0.2]}   # a comment\n"
                                     << "parts:\n  - name: cube\n    mesh: " << mesh
                                     << "\n    initial_pose: {xyz: " << xyz << ", rpy_deg: [0, 0, 30]}\n"
                                     << more;
    return cellModelId(loadCell((dir / "cell.yaml").string()));
  };
  const double id = idOf("cube.stl", "[0, 0, 0.05]");
  EXPECT_EQ(id, std::floor(id));
  EXPECT_LT(id, 4503599627370496.0);                      // 2^52: exact in a heartbeat stat
  EXPECT_EQ(id, idOf("a/other.stl", "[0.0, 0, 0.050]"));  // the same bytes, the same values
  EXPECT_EQ(id, idOf("cube.stl", "[0, 0, 0.05]", "tracker: {delta2: 0.04}\n"));
  EXPECT_NE(id, idOf("cube.stl", "[0, 0, 0.051]"));
  std::ofstream(dir / "a" / "other.stl", std::ios::app) << ' ';  // a mesh edited on one host
  EXPECT_NE(id, idOf("a/other.stl", "[0, 0, 0.05]"));
  EXPECT_NE(id, idOf("missing.stl", "[0, 0, 0.05]"));
  std::filesystem::remove_all(dir);
}

// A missing or broken mesh names the part it belongs to, and the file.
TEST(Config, PartMeshErrorsNameThePart) {
  const std::string parts = std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/";
  const std::string yaml =
      "box: {size: [0.4, 0.3, 0.2]}\nparts:\n"
      "  - {name: cube, mesh: PARTScube.stl, mesh_scale: 2}\n"
      "  - {name: owl, mesh: PARTSno_such_owl.stl}\n";
  const CellConfig cell = loadCellFromString(std::regex_replace(yaml, std::regex("PARTS"), parts));
  const depowder::Mesh cube = loadPartMesh(cell.parts[0]), unit = depowder::loadMesh(parts + "cube.stl");
  ASSERT_EQ(cube.vertices.size(), unit.vertices.size());
  EXPECT_NEAR((cube.vertices[0] - 2 * unit.vertices[0]).norm(), 0, 1e-12);  // at the part's scale
  try {
    loadPartMesh(cell.parts[1]);
    ADD_FAILURE() << "a missing mesh loaded";
  } catch (const depowder::MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("part 'owl'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no_such_owl.stl"), std::string::npos) << e.what();
  }
}

// The tool for the processes that draw or filter it: the planner's nozzle, grown to the flange at
// robot.tool_offset, and robot.effector; a bad key is named.
TEST(Config, ToolFromThePlannerAndRobotSections) {
  const ToolConfig tool = readTool(loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml"));
  EXPECT_DOUBLE_EQ(tool.nozzle_radius, 0.0125);
  EXPECT_NEAR(tool.tube_length, 0.25, 1e-12);
  ASSERT_EQ(tool.effector.size(), 2u);
  EXPECT_DOUBLE_EQ(tool.effector[0].radius, 0.0445);
  const std::string offset = "robot: {tool_offset: {xyz: [0, 0.1, 0.2], rpy_deg: [0, 0, 0]}}\n";
  EXPECT_NEAR(readTool(loadCellFromString(offset)).tube_length, std::sqrt(0.05), 1e-12);  // the offset's length
  EXPECT_NEAR(readTool(loadCellFromString(offset + "planner: {nozzle: {length: 0.3}}\n")).tube_length, 0.3, 1e-12);
  try {
    readTool(loadCellFromString("planner: {nozzle: {radius: -1}}\n", "tool.yaml"));
    ADD_FAILURE() << "a negative nozzle radius was taken";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("planner.nozzle.radius"), std::string::npos) << e.what();
  }
}

// The tools that only talk on the bus take it from the cell file's lcm section, read alone (a
// broken part section does not keep an ESTOP off the bus); --url / --prefix win. They once used
// the command line only, so an ESTOP for a cell with a prefix went to another channel.
TEST(Config, ToolBusIsTheCellFilesUnlessGiven) {
  char dir_template[] = "/tmp/depowder_toolbus_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::filesystem::path dir(dir_template);
  const std::string cell = (dir / "cell.yaml").string();
  std::ofstream(cell) << "lcm: {prefix: B_, url: \"udpm://239.255.76.68:7667?ttl=0\"}\n"
                      << "parts: [{name: broken}]\n";  // no mesh: loadCell would refuse it
  LcmConfig lcm = toolBus("test", cell, std::nullopt, std::nullopt);
  EXPECT_EQ(lcm.prefix, "B_");
  EXPECT_EQ(lcm.url, "udpm://239.255.76.68:7667?ttl=0");
  lcm = toolBus("test", cell, std::string("udpm://239.255.76.69:7667?ttl=0"), std::string(""));
  EXPECT_EQ(lcm.prefix, "");
  EXPECT_EQ(lcm.url, "udpm://239.255.76.69:7667?ttl=0");
  // A cell file given that cannot be read, or with a wrong key in its lcm section: an error.
  EXPECT_THROW(toolBus("test", (dir / "none.yaml").string(), std::nullopt, std::nullopt), ConfigError);
  std::ofstream(cell) << "lcm: {prefx: B_}\n";
  EXPECT_THROW(toolBus("test", cell, std::nullopt, std::nullopt), ConfigError);
  std::filesystem::remove_all(dir);
}
