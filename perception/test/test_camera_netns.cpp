// depowder-camera as a process, over udpm inside a private network namespace (run it
// through test/netns-run; ctest does): live frames from two cameras become one POINTS per
// time step, identical to the library's output; corrupt frames are counted and the
// process keeps running; a frame from the far future does not stop the stream; recorded
// scans play in order past a corrupt file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "camera_run.hpp"
#include "depowder/child_process.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/perception/camera_proxy.hpp"
#include "depowder/stats.hpp"
#include "synthetic.hpp"

using namespace depowder;
using namespace depowder::perception;
using namespace depowder::perception::testing;
using namespace depowder::testutil;
namespace fs = std::filesystem;

namespace {

const std::string kBinary = std::string(DEPOWDER_BIN_DIR) + "/depowder-camera";
const std::string kCell = std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml";

std::string uniquePrefix(const std::string& name) { return "T" + std::to_string(::getpid()) + "_" + name + "_"; }

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The pace of a live run: how fast the frames come and how long depowder-camera waits for a
// late one (the cell's max_wait, stale_after and silent_after).
struct Pace {
  double rate_hz, max_wait, stale_after, silent_after;
};
// The default cell's, at the cameras' 30 Hz. A sanitized build is about ten times slower: on a
// loaded 2-core machine its node, at 30 Hz, lost up to 17 of 90 steps' frames in its socket,
// and a cloud that waited for nothing came out 35-43 ms after its frame, about the default
// max_wait itself. So it runs at 10 Hz and waits five times longer, so that what is tested (a
// step waits for its late camera, then no longer) stays far from the time a frame takes.
#ifdef DEPOWDER_SANITIZE
const Pace kPace{10, 0.2, 1.0, 2.0};
#else
const Pace kPace{30, 0.04, 0.5, 1.0};
#endif

// The cell file of the live runs: the default cell, or a copy of it at kPace.
std::string liveCell() {
  std::string text = readFile(kCell);
  bool changed = false;
  for (const auto& [key, value] : {std::pair{"max_wait", kPace.max_wait},
                                   {"stale_after", kPace.stale_after},
                                   {"silent_after", kPace.silent_after}}) {
    const std::string from = "\n  " + std::string(key) + ": ";
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << kCell << " has no '" << key << "'";
    if (at == std::string::npos) continue;
    const std::size_t value_at = at + from.size(), value_end = text.find_first_of(" #\n", value_at);
    const std::string old_value = text.substr(value_at, value_end - value_at), new_value = std::to_string(value);
    changed |= std::stod(old_value) != value;
    text.replace(value_at, value_end - value_at, new_value);
  }
  if (!changed) return kCell;
  const std::string parts = "mesh: parts/";
  for (auto at = text.find(parts); at != std::string::npos; at = text.find(parts, at + 1))
    text.replace(at, parts.size(), "mesh: " + std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/");
  const std::string path =
      (fs::temp_directory_path() / ("paced_cell_" + std::to_string(::getpid()) + ".yaml")).string();
  std::ofstream(path) << text;
  return path;
}

// A live run at kPace of the default cell's LEFT and RIGHT (`cams`, as synthetic::defaultRig),
// each sending its frame of `frames` every step. removeFiles(run) deletes what it made.
CameraRunConfig liveRun(const std::string& name, const std::vector<PinholeCamera>& cams,
                        const std::vector<DepthImage>& frames, int steps) {
  CameraRunConfig run;
  run.binary = kBinary;
  run.extra_args = {"--cell", liveCell()};
  run.prefix = uniquePrefix(name);
  run.log_path = (fs::temp_directory_path() / (run.prefix + "camera.log")).string();
  run.steps = steps;
  run.rate_hz = kPace.rate_hz;
  run.cameras = cams;
  run.frames = {{frames[0]}, {frames[1]}};
  return run;
}

void removeFiles(const CameraRunConfig& run) {
  fs::remove(run.log_path);
  if (run.extra_args[1] != kCell) fs::remove(run.extra_args[1]);
}

// The library's message for the frames of one time step (what depowder-camera must publish).
point_cloud_t expectedCloud(const std::vector<PinholeCamera>& cams, const std::vector<DepthImage>& frames,
                            const std::vector<int>& which) {
  PerceptionConfig cfg;
  CameraProxy proxy(cfg, {0.40, 0.30, 0.20});
  for (int c : which) EXPECT_TRUE(proxy.addDepth(frames[c], cams[c], 1).ok());
  const auto out = proxy.poll(1);
  EXPECT_EQ(out.size(), 1u);
  return node::encodeCloud(out.at(0).points, 0, cfg.resolution);
}

}  // namespace

TEST(CameraNetns, LiveFramesBecomeOnePointsPerTimeStepAndCorruptFramesAreSurvived) {
  ASSERT_TRUE(fs::exists(kBinary)) << kBinary;
  // The default cell: LEFT and RIGHT at 320 x 240, posed as synthetic::defaultRig.
  const auto cams = synthetic::defaultRig(320, 240);
  const auto scene = synthetic::boxScene({0.40, 0.30, 0.20}, 0.08, {synthetic::Sphere{{0.02, 0.01, 0.09}, 0.04}});
  const std::vector<DepthImage> frames = {synthetic::render(scene, cams[0], 0), synthetic::render(scene, cams[1], 0)};

  CameraRunConfig run = liveRun("live", cams, frames, 90);  // 3 s at 30 Hz
  run.fault = [](int step, int camera, depth_image_t& msg, node::Bus& bus) {
    if (step == 30 && camera == 1) msg.width += 1;                                  // header disagrees with the data
    if (step == 45 && camera == 0) std::fill(msg.data.begin(), msg.data.end(), 0);  // no return at all
    if (step == 60 && camera == 0) {                                                // not a depth_image_t at all
      const std::string junk(100, 'x');
      bus.publishRaw("DEPTH_LEFT", junk.data(), static_cast<int>(junk.size()));
      return false;
    }
    return true;
  };
  const CameraRunResult r = runCamera(run);
  ASSERT_TRUE(r.error.empty()) << r.error << "\n" << readFile(run.log_path);

  const point_cloud_t both = expectedCloud(cams, frames, {0, 1}), left = expectedCloud(cams, frames, {0}),
                      right = expectedCloud(cams, frames, {1});
  ASSERT_EQ(r.clouds.size(), 90u) << "frames_out " << r.stat("frames_out") << ", frames_in " << r.stat("frames_in")
                                  << "\n"
                                  << readFile(run.log_path);
  for (int step = 0; step < 90; ++step) {
    const point_cloud_t& m = r.clouds[step].msg;
    ASSERT_EQ(m.seq, step);
    const auto& published = r.published_utimes[step];
    std::vector<std::string> sources = {"LEFT", "RIGHT"};
    const point_cloud_t* expected = &both;
    if (step == 30) sources = {"LEFT"}, expected = &left;
    if (step == 45 || step == 60) sources = {"RIGHT"}, expected = &right;
    EXPECT_EQ(m.sources, sources) << "step " << step;
    ASSERT_EQ(m.num_sources, static_cast<int>(sources.size()));
    // POINTS carries the newest source frame's utime.
    std::int64_t newest = 0;
    for (std::size_t k = 0; k < sources.size(); ++k) {
      const std::int64_t u = published[sources[k] == "LEFT" ? 0 : 1];
      EXPECT_EQ(m.source_utimes[k], u);
      newest = std::max(newest, u);
    }
    EXPECT_EQ(m.utime, newest);
    EXPECT_EQ(m.frame, "cell");
    // Bit-identical to the library's cloud for the same frames.
    ASSERT_EQ(m.num_points, expected->num_points) << "step " << step;
    EXPECT_EQ(m.xyz, expected->xyz) << "step " << step;
    EXPECT_EQ(m.resolution, expected->resolution);
  }
  // Health: every drop counted by reason, the process still running until told to stop.
  EXPECT_EQ(r.last_heartbeat.state, +heartbeat_t::STOPPING);
  EXPECT_EQ(r.exit_code, 0) << readFile(run.log_path);
  EXPECT_EQ(r.stat("frames_in"), 179);  // 180 sent, one not decodable
  EXPECT_EQ(r.stat("frames_out"), 90);
  EXPECT_EQ(r.stat("frames_partial"), 3);
  EXPECT_EQ(r.stat("dropped_size_mismatch"), 1);
  EXPECT_EQ(r.stat("dropped_no_valid_returns"), 1);
  EXPECT_EQ(r.last_heartbeat.decode_errors, 1);
  EXPECT_EQ(r.last_heartbeat.dropped, 2);
  EXPECT_GE(r.stat("age_s_LEFT"), 0);
  // Its log says why, in words.
  const std::string log = readFile(run.log_path);
  EXPECT_NE(log.find("camera 'RIGHT': frame 30 carries 76800 depth pixels but its header says 321x240"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("camera 'LEFT': frame 45 has no valid return"), std::string::npos) << log;
  EXPECT_NE(log.find("could not decode a 100-byte message on " + run.prefix + "DEPTH_LEFT"), std::string::npos) << log;
  removeFiles(run);
}

TEST(CameraNetns, SilentCameraIsReportedAndDoesNotStallTheStream) {
  const auto cams = synthetic::defaultRig(320, 240);
  const auto scene = synthetic::boxScene({0.40, 0.30, 0.20}, 0.08, {});
  // 2.5 s at 30 Hz; RIGHT dies after 15 steps
  CameraRunConfig run =
      liveRun("silent", cams, {synthetic::render(scene, cams[0], 0), synthetic::render(scene, cams[1], 0)}, 75);
  run.fault = [](int step, int camera, depth_image_t&, node::Bus&) { return !(camera == 1 && step >= 15); };
  run.grace_s = 0.3;
  const CameraRunResult r = runCamera(run);
  ASSERT_TRUE(r.error.empty()) << r.error;
  // Every time step still comes out. RIGHT is waited for (max_wait) until its newest frame
  // lags the newest frame by stale_after, then no longer: those steps are not "partial" any
  // more, and come out at once. After silent_after it is reported silent. At 30 Hz with the
  // default cell's 40 ms and 0.5 s, steps 15 to 28 time out waiting: 14 partial steps, about
  // (stale_after + one period - max_wait) x rate.
  ASSERT_EQ(r.clouds.size(), 75u) << readFile(run.log_path);
  for (int step = 0; step < 75; ++step) EXPECT_EQ(r.clouds[step].msg.num_sources, step < 15 ? 2 : 1) << step;
  const double partial = (kPace.stale_after + 1 / kPace.rate_hz - kPace.max_wait) * kPace.rate_hz;
  EXPECT_NEAR(r.stat("frames_partial"), partial, 2.5);
  std::vector<double> late_ms;
  for (int step = 60; step < 75; ++step)
    late_ms.push_back((r.clouds[step].receive_utime - r.clouds[step].msg.utime) / 1000.0);
  EXPECT_LT(percentile(late_ms, 0.5), 875 * kPace.max_wait);  // no longer waiting max_wait for RIGHT
  EXPECT_GT(r.stat("age_s_RIGHT"), kPace.silent_after + 0.5);
  EXPECT_EQ(r.last_heartbeat.state, +heartbeat_t::STOPPING);
  EXPECT_NE(r.last_heartbeat.state_reason.find("camera RIGHT silent for"), std::string::npos)
      << r.last_heartbeat.state_reason;
  removeFiles(run);
}

// A DEPTH frame stamped a year ahead is refused as a bad stamp: the camera's next frame does not
// confirm a clock jumped forward. Its time step goes out with the other camera alone, and nothing
// else changes: no time step from the future, no restart, no frame late.
TEST(CameraNetns, AFrameFromTheFarFutureIsRefused) {
  const auto cams = synthetic::defaultRig(320, 240);
  const auto scene = synthetic::boxScene({0.40, 0.30, 0.20}, 0.08, {});
  CameraRunConfig run =
      liveRun("future", cams, {synthetic::render(scene, cams[0], 0), synthetic::render(scene, cams[1], 0)}, 60);
  constexpr std::int64_t kYear = 365LL * 24 * 3600 * 1'000'000;
  run.fault = [](int step, int camera, depth_image_t& msg, node::Bus&) {
    if (step == 30 && camera == 0) msg.utime += kYear;
    return true;
  };
  run.grace_s = 0.5;
  const CameraRunResult r = runCamera(run);
  ASSERT_TRUE(r.error.empty()) << r.error;
  const std::string log = readFile(run.log_path);
  ASSERT_EQ(r.clouds.size(), 60u) << log;
  EXPECT_EQ(r.stat("frames_in"), 120) << log;
  EXPECT_EQ(r.stat("dropped_ahead"), 1) << log;
  EXPECT_EQ(r.stat("dropped_late"), 0) << log;
  EXPECT_EQ(r.stat("clock_restarts"), 0) << log;
  for (std::size_t k = 0; k < r.clouds.size(); ++k) {
    const auto& published = r.published_utimes[k];  // LEFT's of step 30 is the year-ahead one
    EXPECT_EQ(r.clouds[k].msg.utime, k == 30 ? published[1] : std::max(published[0], published[1])) << k;
    EXPECT_EQ(r.clouds[k].msg.num_sources, k == 30 ? 1 : 2) << k;
  }
  EXPECT_EQ(r.clouds[30].msg.sources, std::vector<std::string>{"RIGHT"});
  EXPECT_NE(log.find("s ahead of the newest frame taken and the time since"), std::string::npos) << log;
  EXPECT_EQ(r.exit_code, 0) << log;
  removeFiles(run);
}

TEST(CameraNetns, RecordedScansPlayInOrderPastACorruptFile) {
  const fs::path dir = fs::temp_directory_path() / uniquePrefix("scans");
  fs::create_directories(dir);
  // 1: a PLY of a 3 x 3 patch at 5 mm spacing (one point in the middle of each 5 mm voxel),
  // 2: corrupt, 3: a PCD of a 2 x 2 patch and one point outside the box. Patches, because a
  // lone voxel is removed as an outlier. The scans' camera frame is the cell frame.
  {
    std::ofstream ply(dir / "1.ply");
    ply << "ply\nformat ascii 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\n"
           "end_header\n";
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) ply << 0.0025 + 0.005 * i << " " << 0.0025 + 0.005 * j << " 0.1025\n";
  }
  std::ofstream(dir / "2.pcd") << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4\n";
  std::ofstream(dir / "3.pcd")
      << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
         "WIDTH 5\nHEIGHT 1\nPOINTS 5\nDATA ascii\n0.0525 0.0525 0.0525\n0.0575 0.0525 0.0525\n"
         "0.0525 0.0575 0.0525\n0.0575 0.0575 0.0525\n0.5 0.5 0.5\n";
  const std::string prefix = uniquePrefix("files");
  node::Bus listener(kListenUrl, prefix);
  std::vector<point_cloud_t> clouds;
  heartbeat_t last;
  listener.subscribe<point_cloud_t>("POINTS", [&](const point_cloud_t& m, const std::string&) { clouds.push_back(m); });
  listener.subscribe<heartbeat_t>("HEARTBEAT", [&](const heartbeat_t& m, const std::string&) {
    if (m.process == "depowder-camera") last = m;
  });
  const std::string log = (fs::temp_directory_path() / (prefix + "camera.log")).string();
  // 0.4 Hz: each scan is stamped 5 s after the last one taken, which is no clock jumping
  // forward, since 5 s passed on the wall clock too (frame_merger.hpp).
  ChildProcess child({kBinary, "--cell", kCell, "--prefix", prefix, "--files", dir.string(), "--rate", "0.4",
                      "--camera-pose", "0,0,0,0,0,0", "--camera-name", "SCANNER"},
                     log);
  int exit_code = -1;
  for (auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       exit_code < 0 && std::chrono::steady_clock::now() < end;) {
    listener.spinOnce(20);
    exit_code = child.wait(0);
  }
  for (int i = 0; i < 10; ++i) listener.spinOnce(20);  // the last heartbeat
  EXPECT_EQ(exit_code, 0) << readFile(log);
  ASSERT_EQ(clouds.size(), 2u) << readFile(log);
  EXPECT_EQ(clouds[0].num_points, 9);  // nine 5 mm voxels
  EXPECT_EQ(clouds[1].num_points, 4);  // the fifth point is outside the box
  EXPECT_EQ(clouds[0].sources, std::vector<std::string>{"SCANNER"});
  EXPECT_EQ(clouds[1].seq, 1);
  const auto decoded = node::decodeCloud(clouds[1]);
  ASSERT_TRUE(decoded);
  EXPECT_LT((decoded->at(0) - Eigen::Vector3d(0.0525, 0.0525, 0.0525)).norm(), 0.0005);
  EXPECT_NE(readFile(log).find("2.pcd: not a PCD file (no DATA line in the header)"), std::string::npos)
      << readFile(log);
  EXPECT_EQ(node::heartbeatStat(last, "dropped_unreadable"), 1);
  fs::remove_all(dir);
  fs::remove(log);
}
