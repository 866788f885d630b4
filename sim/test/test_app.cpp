// depowder-sim's configuration and process: the default cell and the scenarios load; bad sim
// keys and broken meshes give errors naming the file and the key; a seeded --fast run is
// bit-identical twice (every DEPTH_* and SIM_TRUTH message of an LCM log).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>

#include "depowder/child_process.hpp"
#include "depowder/depth_image_t.hpp"
#include "depowder/sim_truth_t.hpp"
#include "setup.hpp"

using namespace depowder;
using namespace depowder::sim;
namespace fs = std::filesystem;

namespace {

const std::string kSource = DEPOWDER_SOURCE_DIR;
const std::string kCell = kSource + "/config/cell.yaml";

// A scratch directory for this test executable, removed at exit.
fs::path scratch() {
  struct Dir {
    fs::path path = fs::temp_directory_path() / ("depowder_sim_test_" + std::to_string(::getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path;
}

std::string write(const std::string& name, const std::string& text) {
  const fs::path p = scratch() / name;
  std::ofstream(p) << text;
  return p.string();
}

// A small cell with the project's cube, plus `sim` (YAML text of the sim section's body).
std::string cellWithSim(const std::string& name, const std::string& sim, const std::string& mesh = "") {
  return write(name,
               "box: {size: [0.4, 0.3, 0.2], wall: 0.01}\n"
               "cameras:\n  - {name: A, position: [0, -0.45, 0.55], look_at: [0, 0, 0.05]}\n"
               "parts:\n  - {name: cube, mesh: " +
                   (mesh.empty() ? kSource + "/config/parts/cube.stl" : mesh) +
                   ", initial_pose: {xyz: [0, 0, 0.03]}}\n"
                   "sim:\n" +
                   sim);
}

void expectConfigError(const std::string& sim, const std::vector<std::string>& needles) {
  const std::string file = cellWithSim("bad.yaml", sim);
  try {
    loadSimSetup(file);
    ADD_FAILURE() << "accepted: " << sim;
  } catch (const node::ConfigError& e) {
    for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

int run(const std::string& args, const std::string& log = "") {
  std::string cmd = std::string(DEPOWDER_BIN_DIR) + "/depowder-sim " + args + " > " + (scratch() / "out.txt").string() +
                    " 2> " + (scratch() / "err.txt").string();
  if (!log.empty()) cmd = "LCM_DEFAULT_URL='file://" + log + "?mode=w' " + cmd;
  return testutil::shellExitStatus(cmd);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// (channel, payload) of every event of a log, heartbeats left out (they carry wall time and CPU).
std::vector<std::pair<std::string, std::string>> readLog(const std::string& path) {
  lcm::LogFile log(path, "r");
  std::vector<std::pair<std::string, std::string>> events;
  if (!log.good()) return events;
  while (const lcm::LogEvent* e = log.readNextEvent())
    if (e->channel != "HEARTBEAT")
      events.emplace_back(e->channel, std::string(static_cast<const char*>(e->data), e->datalen));
  return events;
}

}  // namespace

TEST(SimSetup, DefaultCellAndScenariosLoad) {
  const SimSetup def = loadSimSetup(kCell);
  ASSERT_EQ(def.parts.size(), 1u);
  EXPECT_EQ(def.parts[0].name, "pipe");
  EXPECT_EQ(def.cameras.size(), 2u);
  EXPECT_EQ(def.script.size(), 2u);
  EXPECT_EQ(def.step_hz, 120);
  EXPECT_EQ(def.cameras[0].noise.sigma_per_m, node::CameraNoise{}.sigma_per_m);

  const SimSetup stat = loadSimSetup(kCell, kSource + "/config/scenarios/static.yaml");
  EXPECT_EQ(stat.visibility_part, "cube");
  EXPECT_NEAR(makeWorld(stat)->truth().parts.at(0).eta, 0.6, 1e-9);

  const SimSetup two = loadSimSetup(kSource + "/config/scenarios/two_cubes.yaml");
  EXPECT_EQ(two.parts.size(), 2u);
  EXPECT_EQ(two.script.size(), 4u);

  // A sim-only overlay keeps the cell's parts and replaces the sim section.
  const SimSetup overlay = loadSimSetup(kCell, kSource + "/config/scenarios/pipe_static.yaml");
  EXPECT_EQ(overlay.cell_file, kCell);
  EXPECT_EQ(overlay.parts.at(0).name, "pipe");
  EXPECT_NEAR(makeWorld(overlay)->truth().parts.at(0).eta, 0.4, 1e-9);
}

TEST(SimApp, ASilencedCameraPublishesNothingForItsWindow) {
  // sim.faults: camera A silent from 0.3 s for 0.4 s; 30 Hz over 1 s gives 30 - 12 frames.
  const std::string cell = cellWithSim("faults.yaml", "  faults: [{at: 0.3, silence_camera: A, duration: 0.4}]\n");
  const std::string log = (scratch() / "faults.lcmlog").string();
  ASSERT_EQ(run("--cell " + cell + " --fast --duration 1.0", log), 0) << slurp(scratch() / "err.txt");
  std::vector<std::int64_t> utimes;
  lcm::LogFile file(log, "r");
  while (const lcm::LogEvent* e = file.readNextEvent())
    if (e->channel == "DEPTH_A") {
      depth_image_t m;
      ASSERT_GT(m.decode(e->data, 0, e->datalen), 0);
      utimes.push_back(m.utime);
    }
  EXPECT_EQ(utimes.size(), 18u);
  for (const std::int64_t u : utimes) EXPECT_TRUE(u < 300000 || u >= 700000) << u;
  EXPECT_NE(slurp(scratch() / "out.txt").find("camera A silent for 0.4"), std::string::npos);
}

TEST(SimSetup, CameraTruthRendersFromItsPoseAndKeepsTheCellsForTheFrames) {
  const SimSetup s = loadSimSetup(cellWithSim(
      "truth.yaml", "  camera_truth: [{camera: A, pose: {xyz: [0.01, -0.44, 0.56], rpy_deg: [-140, 1, 2]}}]\n"));
  const Pose cell = lookAt({0, -0.45, 0.55}, {0, 0, 0.05});
  ASSERT_TRUE(s.cameras.at(0).T_cell_camera_claimed.has_value());
  EXPECT_LT(translationDistance(*s.cameras.at(0).T_cell_camera_claimed, cell), 1e-12);
  EXPECT_LT(rotationDistanceDeg(*s.cameras.at(0).T_cell_camera_claimed, cell), 1e-5);  // acos near 1
  const Pose truth = makePoseRpy({0.01, -0.44, 0.56}, -140 * M_PI / 180, M_PI / 180, 2 * M_PI / 180);
  EXPECT_LT(translationDistance(s.cameras.at(0).T_cell_camera, truth), 1e-12);
  EXPECT_LT(rotationDistanceDeg(s.cameras.at(0).T_cell_camera, truth), 1e-5);
  EXPECT_FALSE(loadSimSetup(cellWithSim("none.yaml", "  seed: 2\n")).cameras.at(0).T_cell_camera_claimed);
  // Its frames carry the claimed pose, not the one they were rendered from.
  EXPECT_LT(translationDistance(makeWorld(s)->render(0).T_cell_camera, cell), 1e-12);
}

TEST(SimSetup, BadSimKeysNameTheFileTheKeyAndTheRange) {
  expectConfigError("  bogus: 1\n", {"bad.yaml", "unknown key 'bogus'", "'sim'"});
  expectConfigError("  powder: {repose_deg: 80}\n", {"bad.yaml", "'sim.powder.repose_deg'", "[5, 60]"});
  expectConfigError("  powder: {cell_size: fine}\n", {"'sim.powder.cell_size'", "a number"});
  expectConfigError("  visibility: {part: owl, eta: 0.5}\n", {"'sim.visibility.part'", "owl"});
  expectConfigError("  visibility: {part: cube, eta: 1.5}\n", {"'sim.visibility.eta'", "[0, 1]"});
  expectConfigError("  truth: {band_inner: 0.02, band_outer: 0.01}\n", {"'sim.truth.band_outer'"});
  expectConfigError("  script: {segments: [{orbit: {period: 0}}]}\n", {"'sim.script.segments[0].orbit.period'"});
  expectConfigError("  script: {segments: [{}]}\n", {"'sim.script.segments[0]'", "exactly one"});
  expectConfigError("  script: {segments: [{waypoints: [{t: 1, xyz: [0, 0, 0.1]}, {t: 0.5, xyz: [0, 0, 0.1]}]}]}\n",
                    {"'sim.script.segments[0].waypoints[1].t'", "later"});
  expectConfigError("  script: {segments: [{waypoints: [{t: 0, xyz: [0, 0, 0.1], tool: hoover}]}]}\n",
                    {"'sim.script.segments[0].waypoints[0].tool'", "off, vacuum, air"});
  expectConfigError("  faults: [{at: 1}]\n", {"'sim.faults[0]'", "exactly one"});
  expectConfigError("  faults: [{at: 1, silence_camera: B, duration: 1}]\n", {"'sim.faults[0].silence_camera'", "'B'"});
  expectConfigError("  faults: [{at: 1, drop_controller: true}]\n", {"'sim.faults'", "arm: emulator"});
  expectConfigError("  faults: [{silence_camera: A}]\n", {"'sim.faults[0].at'"});
  expectConfigError("  camera_truth: [{camera: B, pose: {xyz: [0, 0, 1]}}]\n", {"'sim.camera_truth[0].camera'", "'B'"});
  expectConfigError("  camera_truth: [{camera: A}]\n", {"'sim.camera_truth[0].pose'", "required"});
  expectConfigError("  camera_truth: [{camera: A, pose: {xyz: [0, 0, 1]}}, {camera: A, pose: {xyz: [0, 0, 1]}}]\n",
                    {"'sim.camera_truth[1].camera'", "twice"});
  // An overlay may hold nothing but the sim section.
  const std::string overlay = write("overlay.yaml", "sim: {seed: 3}\ntracker: {}\n");
  try {
    loadSimSetup(kCell, overlay);
    ADD_FAILURE();
  } catch (const node::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("overlay.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'tracker'"), std::string::npos) << e.what();
  }
}

TEST(SimSetup, BrokenMeshNamesThePartAndTheFile) {
  const std::string garbage = write("broken.stl", "solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0\n");
  const std::string cell = cellWithSim("broken_mesh.yaml", "  seed: 1\n", garbage);
  try {
    loadSimSetup(cell);
    ADD_FAILURE();
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find(garbage), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("part 'cube'"), std::string::npos) << e.what();
  }
  const std::string missing = cellWithSim("missing_mesh.yaml", "  seed: 1\n", (scratch() / "nope.obj").string());
  EXPECT_THROW(loadSimSetup(missing), MeshError);
}

TEST(SimProcess, ErrorsExitNonZeroWithTheReason) {
  const std::string bad = cellWithSim("bad_process.yaml", "  step_hz: 5\n");
  EXPECT_EQ(run("--config " + bad + " --fast --duration 0.1"), 1);
  const std::string err = slurp(scratch() / "err.txt");
  EXPECT_NE(err.find("bad_process.yaml"), std::string::npos) << err;
  EXPECT_NE(err.find("'sim.step_hz'"), std::string::npos) << err;
  EXPECT_EQ(run("--bogus"), 2);
  EXPECT_EQ(run("--seed -3"), 2);
}

// The config's check (drop_controller needs arm: emulator) holds when --arm overrides the config's
// choice too: the fault would otherwise be announced and do nothing.
TEST(SimProcess, ADroppedControllerWithoutTheEmulatorIsRefusedFromTheCommandLineToo) {
  const std::string cell = cellWithSim("drop.yaml", "  arm: emulator\n  faults: [{at: 0.05, drop_controller: true}]\n");
  EXPECT_EQ(run("--cell " + cell + " --arm script --fast --duration 0.1"), 1);
  const std::string err = slurp(scratch() / "err.txt");
  EXPECT_NE(err.find("needs the emulator"), std::string::npos) << err;
  EXPECT_NE(err.find("--arm script"), std::string::npos) << err;
}

TEST(SimProcess, SeededFastRunIsBitIdenticalTwice) {
  const std::string scenario = kSource + "/config/scenarios/static.yaml";
  const std::string a = (scratch() / "a.lcmlog").string(), b = (scratch() / "b.lcmlog").string(),
                    c = (scratch() / "c.lcmlog").string();
  ASSERT_EQ(run("--scenario " + scenario + " --fast --duration 0.5 --seed 9", a), 0) << slurp(scratch() / "err.txt");
  ASSERT_EQ(run("--scenario " + scenario + " --fast --duration 0.5 --seed 9", b), 0);
  ASSERT_EQ(run("--scenario " + scenario + " --fast --duration 0.5 --seed 10", c), 0);
  const auto ea = readLog(a), eb = readLog(b), ec = readLog(c);
  std::map<std::string, int> count;
  for (const auto& e : ea) ++count[e.first];
  EXPECT_EQ(count["DEPTH_LEFT"], 15);  // 30 fps for 0.5 s
  EXPECT_EQ(count["DEPTH_RIGHT"], 15);
  EXPECT_EQ(count["SIM_TRUTH"], 15);
  EXPECT_TRUE(ea == eb) << "two runs with seed 9 differ";
  EXPECT_FALSE(ea == ec) << "seeds 9 and 10 gave the same images";

  // Depth frames carry the simulated clock and the camera model; truth the set visibility.
  for (const auto& [channel, data] : ea) {
    if (channel == "DEPTH_LEFT") {
      depth_image_t img;
      ASSERT_GT(img.decode(data.data(), 0, static_cast<int>(data.size())), 0);
      EXPECT_EQ(img.utime, std::llround((img.frame + 1) * 1e6 / 30));  // frame k at (k + 1) / 30 s
      EXPECT_EQ(img.width, 320);
      EXPECT_EQ(img.num_bytes, 320 * 240 * 2);
      EXPECT_FLOAT_EQ(img.depth_unit, 0.00025f);
    }
    if (channel == "SIM_TRUTH") {
      sim_truth_t t;
      ASSERT_GT(t.decode(data.data(), 0, static_cast<int>(data.size())), 0);
      ASSERT_EQ(t.num_parts, 1);
      EXPECT_NEAR(t.parts[0].eta, 0.6, 1e-9);
      EXPECT_EQ(t.parts[0].part, "cube");
    }
  }
}
