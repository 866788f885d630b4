// depowder-tracker's logic without a network: options from the cell YAML (defaults, named
// errors), one PART_POSE per part per frame with the frame's utime and the quantised template,
// bad frames reported while tracking goes on, broken meshes refused at start-up.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "depowder/clock.hpp"
#include "depowder/mesh.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/node/yaml.hpp"
#include "scene.hpp"
#include "tracker_node.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

// POINTS as a log played at its pace brings it: arriving at its own utime.
std::vector<part_pose_t> feed(TrackerNode& node, const point_cloud_t& msg) { return node.onPoints(msg, msg.utime); }

const std::string kParts = std::string(DEPOWDER_SOURCE_DIR) + "/config/parts/";
constexpr double kDeepPowder = 0.065;  // m: powder this high leaves both parts under eta1 (cube 6 cm, owl 8.6)

std::string cameras() {
  return "cameras:\n"
         "  - {name: LEFT, position: [0.0, -0.35, 0.75], look_at: [0.0, 0.0, 0.05]}\n"
         "  - {name: RIGHT, position: [0.0, 0.35, 0.75], look_at: [0.0, 0.0, 0.05]}\n";
}

// Two parts at known poses; the cell's initial poses are 2 mm off them.
struct TwoParts {
  Mesh cube = loadMesh(kParts + "cube.stl"), owl = loadMesh(kParts + "owl.stl");
  Pose cube_truth = scene::restingPose(cube, -0.08, 0.0, 0, 0, 0.3);
  Pose owl_truth = scene::restingPose(owl, 0.08, 0.02, 0, 0, -0.4);

  static std::string part(const std::string& name, const Pose& truth, double xi) {
    const Eigen::Vector3d t = truth.translation() + Eigen::Vector3d(0.002, 0.0, 0.0);
    const double yaw = std::atan2(truth.linear()(1, 0), truth.linear()(0, 0)) * 180 / M_PI;
    std::ostringstream s;
    s.precision(10);
    s << "  - {name: " << name << ", mesh: " << kParts << name << ".stl, xi: " << xi << ", initial_pose: {xyz: ["
      << t.x() << ", " << t.y() << ", " << t.z() << "], rpy_deg: [0, 0, " << yaw << "]}}\n";
    return s.str();
  }
  std::string yaml(const std::string& tracker = "{}") const {
    return cameras() + "parts:\n" + part("cube", cube_truth, 0.01) + part("owl", owl_truth, 0.01) +
           "tracker: " + tracker + "\n";
  }
  std::vector<Cloud> frames(int n, double powder_z = 0.02) const {
    std::mt19937 rng(5);
    std::vector<Cloud> out;
    for (int k = 0; k < n; ++k)
      out.push_back(scene::render({{&cube, cube_truth}, {&owl, owl_truth}}, powder_z, {}, rng));
    return out;
  }
};

TEST(TrackerOptions, DefaultCellHasTheLibraryDefaults) {
  const node::CellConfig cell = node::loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml");
  const TrackerNodeOptions o = readTrackerOptions(cell);
  const TrackerConfig d;
  EXPECT_EQ(o.tracker.method, d.method);
  EXPECT_EQ(o.tracker.delta1_deg, d.delta1_deg);
  EXPECT_EQ(o.tracker.delta2, d.delta2);
  EXPECT_EQ(o.tracker.delta3, d.delta3);
  EXPECT_EQ(o.tracker.cad_spacing, d.cad_spacing);
  EXPECT_EQ(o.tracker.icp_leaf, d.icp_leaf);
  EXPECT_EQ(o.tracker.crop_margin, d.crop_margin);
  EXPECT_EQ(o.tracker.min_scan_points, d.min_scan_points);
  EXPECT_EQ(o.tracker.icp.max_iterations, d.icp.max_iterations);
  EXPECT_EQ(o.tracker.icp.max_correspondence_distance, d.icp.max_correspondence_distance);
  EXPECT_EQ(o.tracker.icp.convergence_translation, d.icp.convergence_translation);
  EXPECT_EQ(o.tracker.icp.convergence_rotation, d.icp.convergence_rotation);
  EXPECT_EQ(o.tracker.icp.kernel_scale, d.icp.kernel_scale);
  EXPECT_EQ(o.tracker.icp.normal_min_cos, d.icp.normal_min_cos);
  EXPECT_EQ(o.tracker.icp.normal_radius, d.icp.normal_radius);
  EXPECT_EQ(o.tracker.icp.tangent_weight, d.icp.tangent_weight);
  EXPECT_EQ(o.tracker.icp.scan_weight, d.icp.scan_weight);
  EXPECT_EQ(o.tracker.visibility.powder_radius, d.visibility.powder_radius);
  EXPECT_EQ(o.tracker.visibility.powder_margin, d.visibility.powder_margin);
  EXPECT_EQ(o.tracker.visibility.cover, d.visibility.cover);
  EXPECT_EQ(o.tracker.visibility.powder_scan_margin, d.visibility.powder_scan_margin);
  EXPECT_EQ(o.tracker.filter.data_inflation, d.filter.data_inflation);
  EXPECT_EQ(o.tracker.filter.reset_frames, d.filter.reset_frames);
  EXPECT_EQ(o.tracker.filter.check_every, d.filter.check_every);
  EXPECT_EQ(o.tracker.filter.reset_chi2, d.filter.reset_chi2);
  EXPECT_EQ(o.tracker.filter.reset_deg, d.filter.reset_deg);
  EXPECT_EQ(o.tracker.filter.reset_m, d.filter.reset_m);
  EXPECT_EQ(o.tracker.icp.max_step_rotation, d.icp.max_step_rotation);
  EXPECT_EQ(o.tracker.icp.min_correspondences, d.icp.min_correspondences);
  EXPECT_EQ(o.tracker.icp.reassociate, d.icp.reassociate);
  EXPECT_EQ(o.tracker.status.tracking_min_inlier_ratio, d.status.tracking_min_inlier_ratio);
  EXPECT_EQ(o.tracker.status.tracking_max_rms, d.status.tracking_max_rms);
  EXPECT_EQ(o.tracker.status.lost_min_inlier_ratio, d.status.lost_min_inlier_ratio);
  EXPECT_EQ(o.tracker.status.lost_max_rms, d.status.lost_max_rms);
  EXPECT_EQ(o.tracker.eta1, 0.30);  // from the progress section
  EXPECT_EQ(o.tracker.viewpoints.size(), cell.cameras.size());
  EXPECT_EQ(o.threads, 0);
}

TEST(TrackerOptions, BadKeysAndValuesAreNamed) {
  const TwoParts s;
  auto error = [&](const std::string& tracker) {
    try {
      readTrackerOptions(node::loadCellFromString(s.yaml(tracker), "cell-under-test.yaml"));
    } catch (const node::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string unknown = error("{delta4: 0.1}");
  EXPECT_NE(unknown.find("delta4"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("cell-under-test.yaml"), std::string::npos) << unknown;
  EXPECT_NE(error("{icp: {max_iterations: 0}}").find("max_iterations"), std::string::npos);
  EXPECT_NE(error("{icp: {kernal_scale: 0.002}}").find("kernal_scale"), std::string::npos);
  EXPECT_NE(error("{method: gicp}").find("method"), std::string::npos);
  EXPECT_NE(error("{delta2: -1}").find("delta2"), std::string::npos);
  EXPECT_NE(error("{status: {tracking_max_rms: 0.004, lost_max_rms: 0.002}}").find("lost_max_rms"), std::string::npos);
  EXPECT_NE(error("{visibility: {powder_radius: 0.5}}").find("powder_radius"), std::string::npos);
  EXPECT_NE(error("{icp: {motion_prior: 0.3}}").find("motion_prior"), std::string::npos);  // gone: the filter
  EXPECT_EQ(error("{method: vanilla, icp: {tangent_weight: 0.5}, filter: {data_inflation: 5}}"), "no error");
  EXPECT_NE(error("{template_resolution: .nan}").find("template_resolution"), std::string::npos);
  // Every field of TrackerConfig has its key (icp.reassociate once had none, so it was refused).
  const node::CellConfig cell = node::loadCellFromString(s.yaml("{icp: {reassociate: 0.002}}"));
  EXPECT_EQ(readTrackerOptions(cell).tracker.icp.reassociate, 0.002);
}

TEST(TrackerNode, OnePosePerPartWithTheFrameUtime) {
  const TwoParts s;
  const node::CellConfig cell = node::loadCellFromString(s.yaml());
  TrackerNode node(cell, readTrackerOptions(cell));
  ASSERT_EQ(node.partNames(), (std::vector<std::string>{"cube", "owl"}));
  const std::vector<Cloud> frames = s.frames(5);
  std::vector<part_pose_t> out;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    out = feed(node, node::encodeCloud(frames[k], 1000 + k));
    ASSERT_EQ(out.size(), 2u);
    for (const part_pose_t& m : out) {
      EXPECT_EQ(m.utime, static_cast<std::int64_t>(1000 + k));
      EXPECT_EQ(m.method, "cu");
      EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.part << ": " << m.status_reason;
      EXPECT_EQ(m.status_reason, "");
      EXPECT_EQ(m.template_updated, k == 0) << m.part;
      EXPECT_EQ(m.template_version, 1);
      EXPECT_GT(m.iterations, 0);
      EXPECT_GT(m.inlier_ratio, 0.5);
      EXPECT_GT(m.eta, 0.3);
    }
  }
  EXPECT_EQ(out[0].part, "cube");
  EXPECT_EQ(out[1].part, "owl");
  const Pose cube = *node::fromMsg(out[0].T_cell_part), owl = *node::fromMsg(out[1].T_cell_part);
  // Started 2 mm off; measured 0.2 mm and 1.6 deg (the cube's far face is hidden from both
  // cameras, and its buried rim, within xi of the powder, is in the template).
  EXPECT_LT(translationDistance(cube, s.cube_truth), 0.002);
  EXPECT_LT(rotationAngle(cube.linear(), s.cube_truth.linear()) * 180 / M_PI, 2.5);
  EXPECT_LT(translationDistance(owl, s.owl_truth), 0.002);
  EXPECT_LT(rotationAngle(owl.linear(), s.owl_truth.linear()) * 180 / M_PI, 2.0);

  // The template: part frame, quantised at template_resolution, the tracker's template thinned
  // to template_leaf; every point within half a count of a CAD sample of the template.
  const part_pose_t& m = out[0];
  const PartTracker& tracker = node.trackers().part(0);
  EXPECT_FLOAT_EQ(m.template_resolution, 0.0005f);
  const Indices shown = thinned(tracker.cad().points, tracker.templateIndices(), 0.005);
  ASSERT_EQ(m.template_size, static_cast<std::int32_t>(shown.size()));
  ASSERT_EQ(m.template_xyz.size(), shown.size());
  for (std::size_t i = 0; i < shown.size(); ++i) {
    const Point q(m.template_xyz[i][0], m.template_xyz[i][1], m.template_xyz[i][2]);
    EXPECT_LE((q * m.template_resolution - tracker.cad().points[shown[i]]).cwiseAbs().maxCoeff(), 0.00025 + 1e-9);
  }
}

TEST(TrackerNode, ARestartResumesFromTheSavedPoses) {
  const TwoParts s;
  const node::CellConfig cell = node::loadCellFromString(s.yaml());
  TrackerNode first(cell, readTrackerOptions(cell));
  std::int64_t utime = 5;
  for (const Cloud& frame : s.frames(3)) feed(first, node::encodeCloud(frame, utime++));
  ASSERT_EQ(first.lastPoses().size(), 2u);
  EXPECT_EQ(first.lastPoses().at("cube").utime, 7);

  char dir[] = "/tmp/depowder_tracker_state_XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string path = std::string(dir) + "/tracker.state";
  EXPECT_TRUE(loadTrackerState(path).empty());  // no file yet: a first start
  ASSERT_EQ(saveTrackerState(path, first.lastPoses()), "");
  const std::map<std::string, SavedPose> saved = loadTrackerState(path);
  ASSERT_EQ(saved.size(), 2u);
  for (const auto& [name, p] : first.lastPoses()) {
    EXPECT_EQ(saved.at(name).utime, p.utime);
    EXPECT_LT(translationDistance(saved.at(name).T_cell_part, p.T_cell_part), 1e-12) << name;
    EXPECT_LT(rotationAngle(saved.at(name).T_cell_part.linear(), p.T_cell_part.linear()), 1e-7)
        << name;  // acos resolves ~1e-8
  }
  // The restarted node starts every part from its saved pose, not the cell's initial pose
  // (2 mm off the truth), and skips Phase 1's wait.
  TrackerNode second(cell, readTrackerOptions(cell), saved);
  for (std::size_t i = 0; i < 2; ++i)
    EXPECT_LT(translationDistance(second.trackers().part(i).pose(), saved.at(second.partNames()[i]).T_cell_part),
              1e-12);
  for (const part_pose_t& m : feed(second, node::encodeCloud(s.frames(1)[0], 8)))
    EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.part << ": " << m.status_reason;
  // Even where eta is back under eta1 (the powder deep round the parts, as after a restart early
  // in Phase 2): a new node waits there, a resumed one tracks (it once waited with the pose frozen).
  const Cloud deep = s.frames(1, kDeepPowder)[0];
  TrackerNode fresh(cell, readTrackerOptions(cell));
  for (const part_pose_t& m : feed(fresh, node::encodeCloud(deep, 9)))
    ASSERT_EQ(m.status, +part_pose_t::WAITING) << m.part << ": " << m.status_reason;
  EXPECT_EQ(fresh.stats().last_problem, "");  // Phase 1 is no problem (the heartbeat stays RUNNING)
  TrackerNode third(cell, readTrackerOptions(cell), saved);
  for (const part_pose_t& m : feed(third, node::encodeCloud(deep, 9))) {
    EXPECT_NE(m.status, +part_pose_t::WAITING) << m.part << ": " << m.status_reason;
    EXPECT_EQ(std::string(m.status_reason).find("phase 1"), std::string::npos) << m.status_reason;
  }

  // Vanilla ICP resumed too: its template (the whole model) was once set only on leaving Phase 1,
  // so a resumed part had none and was LOST on every frame.
  const node::CellConfig vanilla = node::loadCellFromString(s.yaml("{method: vanilla}"));
  TrackerNode fourth(vanilla, readTrackerOptions(vanilla), saved);
  for (const part_pose_t& m : feed(fourth, node::encodeCloud(s.frames(1)[0], 8)))
    EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.part << ": " << m.status_reason;

  // A path that is not a readable file is said, not taken for a first start.
  try {
    loadTrackerState(dir);
    ADD_FAILURE() << "a directory taken for a state file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }

  // A broken file names the file and the line.
  for (const char* bad : {"cube 7 0 0 0 1 0 0\n", "cube 7 0 0 0 2 0 0 0\n", "cube 7 nan 0 0 1 0 0 0\n"}) {
    std::ofstream(path) << "owl 7 0 0 0 1 0 0 0\n" << bad;
    try {
      loadTrackerState(path);
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(path + ":2:"), std::string::npos) << e.what();
    }
  }
  std::remove(path.c_str());
  rmdir(dir);
}

TEST(TrackerNode, WithOneCameraSilentTrackingGoesOnWithTheOther) {
  // Frames seen by RIGHT alone (LEFT silent), said so in POINTS' sources: the template is culled
  // with RIGHT only, both parts keep tracking, and the heartbeat's problem names it.
  const TwoParts s;
  const node::CellConfig cell = node::loadCellFromString(s.yaml());
  TrackerNode node(cell, readTrackerOptions(cell));
  scene::SceneConfig right_only;
  right_only.cameras = {scene::defaultCameras()[1]};
  std::mt19937 rng(9);
  std::vector<part_pose_t> out;
  for (int k = 0; k < 5; ++k) {
    point_cloud_t msg = node::encodeCloud(
        scene::render({{&s.cube, s.cube_truth}, {&s.owl, s.owl_truth}}, 0.02, right_only, rng), 100 + k);
    msg.sources = {"RIGHT"};
    msg.source_utimes = {100 + k};
    msg.num_sources = 1;
    out = feed(node, msg);
    for (const part_pose_t& m : out) EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.part << ": " << m.status_reason;
  }
  EXPECT_NE(node.stats().last_problem.find("POINTS from RIGHT only"), std::string::npos) << node.stats().last_problem;
  const Pose cube = *node::fromMsg(out[0].T_cell_part), owl = *node::fromMsg(out[1].T_cell_part);
  EXPECT_LT(translationDistance(cube, s.cube_truth), 0.003);
  EXPECT_LT(rotationAngle(cube.linear(), s.cube_truth.linear()) * 180 / M_PI, 3.0);
  EXPECT_LT(translationDistance(owl, s.owl_truth), 0.003);
  EXPECT_LT(rotationAngle(owl.linear(), s.owl_truth.linear()) * 180 / M_PI, 3.0);

  // Without culling by camera the silent one is said all the same.
  const node::CellConfig no_cull = node::loadCellFromString(s.yaml("{cull_with_cameras: false}"));
  TrackerNode plain(no_cull, readTrackerOptions(no_cull));
  point_cloud_t msg = node::encodeCloud(s.frames(1)[0], 200);
  msg.sources = {"RIGHT"};
  msg.source_utimes = {200};
  msg.num_sources = 1;
  feed(plain, msg);
  EXPECT_EQ(plain.stats().last_problem, "POINTS from RIGHT only");
}

TEST(TrackerNode, BadFramesAreReportedAndTrackingGoesOn) {
  const TwoParts s;
  const node::CellConfig cell = node::loadCellFromString(s.yaml("{method: continuous}"));
  TrackerNode node(cell, readTrackerOptions(cell));
  const std::vector<Cloud> frames = s.frames(2);

  point_cloud_t broken = node::encodeCloud(frames[0], 1);
  broken.resolution = 0;  // an invalid header
  for (const part_pose_t& m : feed(node, broken)) {
    EXPECT_EQ(m.utime, 1);
    EXPECT_EQ(m.status, +part_pose_t::WAITING);  // not started yet: the initial pose
    EXPECT_NE(m.status_reason.find("bad POINTS frame"), std::string::npos) << m.status_reason;
  }
  for (const part_pose_t& m : feed(node, node::encodeCloud(frames[0], 2)))
    EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.status_reason;
  for (const part_pose_t& m : feed(node, node::encodeCloud({}, 3))) {
    EXPECT_EQ(m.status, +part_pose_t::LOST);
    EXPECT_NE(m.status_reason.find("empty scan"), std::string::npos) << m.status_reason;
    EXPECT_NE(m.status_reason.find("last good pose kept"), std::string::npos) << m.status_reason;
  }
  broken.utime = 4;
  for (const part_pose_t& m : feed(node, broken)) EXPECT_EQ(m.status, +part_pose_t::LOST);
  for (const part_pose_t& m : feed(node, node::encodeCloud(frames[1], 5))) {
    EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.status_reason;
    EXPECT_EQ(m.method, "continuous");
    EXPECT_TRUE(m.template_updated);  // continuous: every frame
  }
  EXPECT_EQ(node.stats().frames, 5);
  EXPECT_EQ(node.stats().invalid_frames, 3);
  EXPECT_GT(node.stats().frame_ms_p50, 0.0);
}

// A node on the two parts' cell and two frames to stamp: the tests of POINTS' utimes.
class TrackerNodeStamps : public ::testing::Test {
 protected:
  const TwoParts s;
  const node::CellConfig cell = node::loadCellFromString(s.yaml());
  TrackerNode node{cell, readTrackerOptions(cell)};
  const std::vector<Cloud> frames = s.frames(2);
  static constexpr std::int64_t t = 10'000'000;  ///< us, the first frame's utime
};

// A frame not newer than the one tracked last (a reordered packet, a second camera proxy) is not
// tracked, nor one stamped out of range: tracking it would step the parts back in time. One more
// than kClockJumpBack behind is the clock going back (a log played again): tracked on.
TEST_F(TrackerNodeStamps, FramesOutOfOrderAreRefusedAndAClockGoingBackIsTrackedOn) {
  ASSERT_EQ(feed(node, node::encodeCloud(frames[0], t)).size(), 2u);
  for (const std::int64_t stale : {t, t - 33'000, t - kClockJumpBack}) {
    EXPECT_TRUE(feed(node, node::encodeCloud(frames[1], stale)).empty()) << stale;
    EXPECT_EQ(node.stats().last_problem, "POINTS at utime " + std::to_string(stale) +
                                             ", not newer than the frame tracked last (utime 10000000): reordered, "
                                             "or a second camera proxy publishes POINTS: not tracked");
  }
  EXPECT_TRUE(feed(node, node::encodeCloud(frames[1], -1)).empty());
  EXPECT_NE(node.stats().last_problem.find("utime -1 us, outside 0 to 2^53 us"), std::string::npos);
  EXPECT_EQ(node.stats().refused_frames, 4);
  EXPECT_EQ(node.stats().clock_restarts, 0);
  const std::int64_t replayed = t - kClockJumpBack - 1;
  for (const std::int64_t u : {replayed, replayed + 33'000}) {
    const std::vector<part_pose_t> out = feed(node, node::encodeCloud(frames[1], u));
    ASSERT_EQ(out.size(), 2u);
    for (const part_pose_t& m : out) {
      EXPECT_EQ(m.utime, u);
      EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.part << ": " << m.status_reason;
    }
  }
  EXPECT_EQ(node.stats().clock_restarts, 1);
  EXPECT_EQ(node.stats().frames, 7);
}

// A frame stamped far ahead of the one tracked last and the time since (more than kClockJumpBack)
// is a bad stamp, refused, unless the next runs with it: the cameras' clock jumped forward, and
// tracking goes on from there (counted in clock_restarts, the jump not told to the filters).
TEST_F(TrackerNodeStamps, AFrameStampedFarAheadIsRefusedUnlessTheNextRunsWithIt) {
  const std::int64_t ahead = t + 60'000'000;
  ASSERT_EQ(node.onPoints(node::encodeCloud(frames[0], t), t).size(), 2u);
  EXPECT_TRUE(node.onPoints(node::encodeCloud(frames[1], ahead), t + 33'333).empty());
  EXPECT_EQ(node.stats().last_problem,
            "POINTS at utime 70000000, 60.0 s ahead of the frame tracked last (utime 10000000) and the time since: a "
            "bad stamp, unless the next frame runs with it (the cameras' clock jumped forward): not tracked");
  // Seconds later by both clocks: not ahead, whatever the silence.
  EXPECT_EQ(node.onPoints(node::encodeCloud(frames[1], t + 5'000'000), t + 5'000'000).size(), 2u);
  EXPECT_TRUE(node.onPoints(node::encodeCloud(frames[0], ahead), t + 5'033'333).empty());
  const std::vector<part_pose_t> out = node.onPoints(node::encodeCloud(frames[1], ahead + 33'333), t + 5'066'666);
  ASSERT_EQ(out.size(), 2u);
  for (const part_pose_t& m : out) EXPECT_EQ(m.status, +part_pose_t::TRACKING) << m.part << ": " << m.status_reason;
  EXPECT_EQ(node.stats().refused_frames, 2);
  EXPECT_EQ(node.stats().clock_restarts, 1);
  EXPECT_NEAR(node.stats().max_gap_periods, 150.0, 1e-3);  // the 5 s silence; the jump is not told
}

// The time between two frames tracked, in the cameras' frame periods (30 Hz here), is told to
// the parts' filters (PartTracker::elapse) and its longest is in the stats. A frame refused or
// one after the clock went back tells none.
TEST_F(TrackerNodeStamps, TheTimeBetweenFramesIsToldInFramePeriods) {
  feed(node, node::encodeCloud(frames[0], t));
  EXPECT_EQ(node.stats().max_gap_periods, 0.0);
  feed(node, node::encodeCloud(frames[1], t + 33'333));
  EXPECT_NEAR(node.stats().max_gap_periods, 1.0, 1e-3);
  feed(node, node::encodeCloud(frames[1], t + 33'333));  // not newer: refused
  feed(node, node::encodeCloud(frames[0], t + 2'033'333));
  EXPECT_NEAR(node.stats().max_gap_periods, 60.0, 1e-3);
  feed(node, node::encodeCloud(frames[0], t - 5'000'000));  // the clock went back
  feed(node, node::encodeCloud(frames[1], t - 5'000'000 + 33'333));
  EXPECT_NEAR(node.stats().max_gap_periods, 60.0, 1e-3);
  EXPECT_EQ(node.stats().clock_restarts, 1);
  EXPECT_EQ(node.stats().refused_frames, 1);
}

TEST(TrackerNode, BrokenMeshesAreRefusedAtStartUp) {
  const TwoParts s;
  char dir[] = "/tmp/depowder_tracker_node_XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string empty_stl = std::string(dir) + "/empty.stl";
  std::ofstream(empty_stl) << "solid empty\nendsolid empty\n";
  auto error = [&](const std::string& mesh) {
    const std::string yaml = cameras() + "parts:\n  - {name: broken, mesh: " + mesh + "}\n";
    const node::CellConfig cell = node::loadCellFromString(yaml);
    try {
      TrackerNode node(cell, readTrackerOptions(cell));
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string missing = std::string(dir) + "/missing.stl";
  EXPECT_NE(error(missing).find(missing), std::string::npos) << error(missing);
  EXPECT_NE(error(empty_stl).find(empty_stl), std::string::npos) << error(empty_stl);
  std::remove(empty_stl.c_str());
  rmdir(dir);
}

}  // namespace
