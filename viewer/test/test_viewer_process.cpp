// depowder-viewer as a process, over real LCM (udpm): run inside a private network
// namespace (test/netns-run), with no X display (the viewer starts its own Xvfb).
// Garbage on every channel first (it must keep running and count it), then a known
// scene; the picture must show the model red and the template green where they
// project. Also: --snapshots / --snapshot-on-phase, lcm-logplayer and file:// replay.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <random>
#include <set>
#include <thread>

#include "depowder/child_process.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/test_messages.hpp"
#include "depowder/viewer/display.hpp"
#include "depowder/viewer/renderer.hpp"
#include "picture_checks.hpp"

using namespace depowder;
using namespace depowder::viewer;
using namespace depowder::viewer::test;
namespace fs = std::filesystem;

namespace {

constexpr double kSide = 0.08;  // m, the test cube
const Eigen::Vector3d kBox(0.40, 0.30, 0.20);
const std::vector<std::string> kChannels = {"POINTS",    "PART_POSE",   "PROGRESS",
                                            "SIM_TRUTH", "NOZZLE_PLAN", "ROBOT_STATE"};

double seconds() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

/// Runs depowder-viewer (with no DISPLAY unless `display` is given); stdout and stderr go to `log`.
std::unique_ptr<testutil::ChildProcess> spawnViewer(const std::vector<std::string>& args, const fs::path& log,
                                                    const std::string& display = "") {
  std::vector<std::string> argv{std::string(DEPOWDER_BIN_DIR) + "/depowder-viewer"};
  argv.insert(argv.end(), args.begin(), args.end());
  return std::make_unique<testutil::ChildProcess>(
      argv, log.string(),
      std::vector<std::string>{display.empty() ? "DISPLAY" : "DISPLAY=" + display, "LCM_DEFAULT_URL"});
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

const Pose kEstimate = makePoseRpy({-0.05, 0.01, 0.06}, 0, 0, 0.4);

/// The cube at kEstimate with its top face as the template (0.5 mm counts).
part_pose_t partPose(std::int64_t utime) {
  part_pose_t m = testutil::trackingPose("cube", utime, kEstimate);
  m.template_updated = true;
  m.template_version = 1;
  m.template_resolution = 0.0005f;
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j)
      m.template_xyz.push_back({static_cast<std::int16_t>(12 * i), static_cast<std::int16_t>(12 * j),
                                static_cast<std::int16_t>(kSide / 2 / 0.0005)});
  m.template_size = static_cast<std::int32_t>(m.template_xyz.size());
  return m;
}

point_cloud_t points(std::int64_t seq, std::int64_t utime) {
  Cloud c;
  for (double x = -0.19; x <= 0.19; x += 0.02) c.emplace_back(x, 0.13, 0.02);
  point_cloud_t m = node::encodeCloud(c, utime);
  m.seq = seq;
  return m;
}

progress_t progress(std::int64_t utime, std::int8_t phase) {
  progress_t m{};
  m.utime = utime;
  m.part = "cube";
  m.phase = phase;
  m.eta = phase == progress_t::PHASE_VACUUM_BURIED ? 0.1 : 0.5;
  m.T_cell_part = node::toMsg(kEstimate);
  return m;
}

/// Random bytes and wrong types on every channel; returns how many were sent.
int publishGarbage(node::Bus& bus, std::mt19937& rng) {
  int n = 0;
  for (const std::string& ch : kChannels) {
    std::vector<std::uint8_t> bytes(1 + rng() % 2000);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    bus.publishRaw(ch, bytes.data(), static_cast<int>(bytes.size()));
    heartbeat_t wrong{};
    wrong.process = "impostor";
    bus.publish(ch, wrong);
    n += 2;
  }
  return n;
}

/// Checks a picture of the known scene: size, red model, green template.
void expectKnownScene(const fs::path& png, int width, int height) {
  ASSERT_TRUE(fs::exists(png)) << png;
  const Image img = readPng(png.string());
  ASSERT_EQ(img.width, width);
  ASSERT_EQ(img.height, height);
  const CameraSetup cam = defaultCamera(kBox);
  auto px = [&](const Eigen::Vector3d& p) { return project(cam, width, height, p); };
  const double s = 0.5 * kSide;
  for (const Eigen::Vector3d& t : {Eigen::Vector3d(0, 0, s), Eigen::Vector3d(0.024, 0.024, s)})
    EXPECT_TRUE(anyNear(img, px(kEstimate * t), 1, isGreen)) << "template at " << px(kEstimate * t).transpose();
  for (const Eigen::Vector3d& f : {Eigen::Vector3d(0, -s, 0), Eigen::Vector3d(-s, 0, -0.01)}) {
    const Eigen::Vector2d uv = px(kEstimate * f);
    EXPECT_TRUE(isRed(img.at(static_cast<int>(uv.x()), static_cast<int>(uv.y())))) << "model at " << uv.transpose();
  }
  EXPECT_GT(count(img, isRed), 200);
}

class ViewerProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("depowder_viewer_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    saveStl(cubeMesh(kSide), (dir_ / "cube.stl").string());
    std::ofstream(dir_ / "cell.yaml") << "box: {size: [0.40, 0.30, 0.20]}\n"
                                         "parts:\n  - name: cube\n    mesh: cube.stl\n";
    bus_ = std::make_unique<node::Bus>("udpm://239.255.76.67:7667?ttl=0");
    bus_->subscribe<heartbeat_t>("HEARTBEAT", [this](const heartbeat_t& m, const std::string&) {
      if (m.process == "depowder-viewer") heartbeat_ = m, ++heartbeats_;
    });
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  /// Spins the test's bus until `done` or `timeout_s`; calls `each` every `period_s`.
  bool spinUntil(const std::function<bool()>& done, double timeout_s, const std::function<void()>& each = {},
                 double period_s = 0.05) {
    const double end = seconds() + timeout_s;
    double next = 0;
    while (seconds() < end) {
      if (done()) return true;
      if (each && seconds() >= next) {
        each();
        next = seconds() + period_s;
      }
      bus_->spinOnce(10);
    }
    return done();
  }
  std::string log() const { return slurp(dir_ / "viewer.log"); }

  fs::path dir_;
  std::unique_ptr<node::Bus> bus_;
  heartbeat_t heartbeat_{};
  int heartbeats_ = 0;
};

}  // namespace

TEST_F(ViewerProcess, SurvivesGarbageThenPicturesTheKnownScene) {
  const fs::path png = dir_ / "out" / "snap.png";
  const auto viewer = spawnViewer(
      {"--config", (dir_ / "cell.yaml").string(), "--snapshot", png.string(), "--size", "640x480", "--timeout", "30"},
      dir_ / "viewer.log");
  // 1. Its heartbeat says it is listening.
  ASSERT_TRUE(spinUntil([&] { return heartbeats_ > 0 || !viewer->running(); }, 20)) << log();
  ASSERT_TRUE(viewer->running()) << log();
  // 2. Garbage on every channel until its heartbeat counts it; it keeps running.
  std::mt19937 rng(7);
  int sent = 0;
  ASSERT_TRUE(spinUntil([&] { return heartbeat_.decode_errors >= 12 || !viewer->running(); }, 10,
                        [&] { sent += publishGarbage(*bus_, rng); }))
      << log();
  ASSERT_TRUE(viewer->running()) << log();
  EXPECT_EQ(heartbeat_.state, +heartbeat_t::RUNNING);
  EXPECT_LE(heartbeat_.decode_errors, sent);
  EXPECT_EQ(heartbeat_.received, 0);
  // 3. The known scene until it has taken its picture and exited.
  std::int64_t seq = 0;
  ASSERT_TRUE(spinUntil([&] { return !viewer->running(); }, 20,
                        [&] {
                          bus_->publish("POINTS", points(seq, 1000 + seq));
                          bus_->publish("PART_POSE", partPose(1000 + seq));
                          bus_->publish("PROGRESS", progress(1000 + seq, progress_t::PHASE_VACUUM_TRACKED));
                          ++seq;
                        }))
      << log();
  EXPECT_EQ(viewer->wait(5), 0) << log();
  expectKnownScene(png, 640, 480);
  EXPECT_NE(log().find("could not decode"), std::string::npos) << log();
}

TEST_F(ViewerProcess, SnapshotsEveryNFramesAndOnPhaseChange) {
  const fs::path every = dir_ / "every", phases = dir_ / "phases";
  const auto viewer = spawnViewer({"--config", (dir_ / "cell.yaml").string(), "--snapshots", every.string(), "--every",
                                   "5", "--snapshot-on-phase", phases.string(), "--size", "320x240"},
                                  dir_ / "viewer.log");
  ASSERT_TRUE(spinUntil([&] { return heartbeats_ > 0 || !viewer->running(); }, 20)) << log();
  for (std::int64_t seq = 0; seq < 12; ++seq) {
    bus_->publish("POINTS", points(seq, 1000 + seq));
    bus_->publish("PART_POSE", partPose(1000 + seq));
    bus_->publish("PROGRESS",
                  progress(1000 + seq, seq < 6 ? progress_t::PHASE_VACUUM_BURIED : progress_t::PHASE_VACUUM_TRACKED));
    spinUntil([] { return false; }, 0.1);
  }
  spinUntil([] { return false; }, 1.0);  // let it finish the last pictures
  ASSERT_TRUE(viewer->running()) << log();
  EXPECT_EQ(viewer->stop(10), 0) << log();

  std::set<std::string> got;
  for (const auto& e : fs::directory_iterator(every)) got.insert(e.path().filename().string());
  EXPECT_EQ(got, (std::set<std::string>{"points-000000.png", "points-000005.png", "points-000010.png"})) << log();
  got.clear();
  for (const auto& e : fs::directory_iterator(phases)) got.insert(e.path().filename().string());
  EXPECT_EQ(got, (std::set<std::string>{"cube-phase1-buried.png", "cube-phase2-tracked.png"})) << log();
  expectKnownScene(every / "points-000010.png", 320, 240);
  expectKnownScene(phases / "cube-phase2-tracked.png", 320, 240);
}

// A recorded run: written as an LCM log, then replayed by lcm-logplayer on the
// namespace's network, and read directly by the viewer (file://, as fast as it goes).
TEST_F(ViewerProcess, ReplaysALogFromLcmLogplayerAndFromFile) {
  const fs::path lcmlog = dir_ / "run.lcmlog";
  {
    lcm::LogFile log(lcmlog.string(), "w");
    ASSERT_TRUE(log.good());
    std::int64_t t = node::nowUtime();
    auto put = [&](const std::string& ch, const auto& msg) {
      ASSERT_EQ(testutil::writeMessage(log, ch, msg, t += 20000), 0);
    };
    std::mt19937 rng(3);
    std::vector<std::uint8_t> junk(333);
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    lcm::LogEvent bad{0, t += 1000, "PART_POSE", static_cast<std::int32_t>(junk.size()), junk.data()};
    ASSERT_EQ(log.writeEvent(&bad), 0);
    for (std::int64_t seq = 0; seq < 7; ++seq) {
      put("POINTS", points(seq, 1000 + seq));
      put("PART_POSE", partPose(1000 + seq));
      put("PROGRESS", progress(1000 + seq, progress_t::PHASE_VACUUM_TRACKED));
    }
  }

  // lcm-logplayer on the network: the viewer sees it like a live cell.
  const fs::path played = dir_ / "played.png";
  const auto viewer = spawnViewer({"--config", (dir_ / "cell.yaml").string(), "--snapshot", played.string(), "--size",
                                   "400x300", "--timeout", "30"},
                                  dir_ / "viewer.log");
  ASSERT_TRUE(spinUntil([&] { return heartbeats_ > 0 || !viewer->running(); }, 20)) << log();
  testutil::ChildProcess player({"lcm-logplayer", lcmlog.string()});
  EXPECT_EQ(player.wait(20), 0);
  EXPECT_EQ(viewer->wait(20), 0) << log();
  expectKnownScene(played, 400, 300);

  // The log read directly, no network, as fast as it goes: every 3rd frame, none skipped,
  // and the viewer ends with the log.
  const fs::path frames = dir_ / "frames";
  const auto direct =
      spawnViewer({"--config", (dir_ / "cell.yaml").string(), "--url", "file://" + lcmlog.string() + "?speed=0",
                   "--snapshots", frames.string(), "--every", "3", "--size", "320x240"},
                  dir_ / "viewer.log");
  EXPECT_EQ(direct->wait(30), 0) << log();
  std::set<std::string> got;
  for (const auto& e : fs::directory_iterator(frames)) got.insert(e.path().filename().string());
  EXPECT_EQ(got, (std::set<std::string>{"points-000000.png", "points-000003.png", "points-000006.png"})) << log();
  expectKnownScene(frames / "points-000006.png", 320, 240);
}

TEST_F(ViewerProcess, LiveWindowWithoutADisplayFailsWithAPlainMessage) {
  const auto viewer = spawnViewer({"--config", (dir_ / "cell.yaml").string()}, dir_ / "viewer.log");
  EXPECT_EQ(viewer->wait(10), 1);
  EXPECT_NE(log().find("no X display"), std::string::npos) << log();
}

// The live window (on a private Xvfb standing in for a desktop): it draws what it hears,
// reports it in its heartbeat, and closes at --duration.
TEST_F(ViewerProcess, LiveWindowDrawsWhatItHears) {
  const std::string saved = std::getenv("DISPLAY") ? std::getenv("DISPLAY") : "";
  Xvfb xvfb(800, 600);
  const auto viewer = spawnViewer({"--config", (dir_ / "cell.yaml").string(), "--duration", "3", "--size", "640x480"},
                                  dir_ / "viewer.log", xvfb.display());
  setenv("DISPLAY", saved.c_str(), 1);
  ASSERT_TRUE(spinUntil([&] { return heartbeats_ > 0 || !viewer->running(); }, 20)) << log();
  std::int64_t seq = 0;
  auto rendered = [&] {
    const double n = node::heartbeatStat(heartbeat_, "frames_rendered");
    return std::isnan(n) ? 0.0 : n;
  };
  const double before = rendered();
  EXPECT_TRUE(spinUntil([&] { return rendered() >= before + 5 || !viewer->running(); }, 3,
                        [&] {
                          bus_->publish("POINTS", points(seq, 1000 + seq));
                          bus_->publish("PART_POSE", partPose(1000 + seq));
                          ++seq;
                        }))
      << log();
  EXPECT_TRUE(viewer->running());
  EXPECT_EQ(viewer->wait(10), 0) << log();
}
