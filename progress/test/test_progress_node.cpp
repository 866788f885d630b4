// depowder-progress's logic without a network: YAML options, POINTS / PART_POSE pairing,
// stale and invalid poses, the initial pose in phase 1, and the air-blast pass to DONE.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "depowder/clock.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "progress_node.hpp"
#include "scenes.hpp"

namespace depowder::progress {
namespace {

// The committed 6 cm cube, centred at (0, 0, 0.05): bottom 2 cm, top 8 cm.
std::string cellYaml(const std::string& progress_section = "{}", const std::string& xi = "0.01") {
  return std::string("parts:\n  - name: cube\n    mesh: ") + DEPOWDER_SOURCE_DIR +
         "/config/parts/cube.stl\n    xi: " + xi + "\n    initial_pose: {xyz: [0, 0, 0.05], rpy_deg: [0, 0, 0]}\n" +
         "progress: " + progress_section + "\n";
}

Cloud cubeScene(double h, double dx = 0) {
  Cloud scan = test::powderPlane(h, 0.15, 0.0025,
                                 [dx](double x, double y) { return std::abs(x - dx) <= 0.03 && std::abs(y) <= 0.03; });
  for (const Point& p : test::boxSurface({dx - 0.03, -0.03, 0.02}, {dx + 0.03, 0.03, 0.08}, 0.003))
    if (p.z() >= h) scan.push_back(p);
  return scan;
}

part_pose_t poseMsg(std::int64_t utime, const Pose& pose, const std::string& part = "cube") {
  part_pose_t m;
  m.utime = utime;
  m.part = part;
  m.T_cell_part = node::toMsg(pose);
  m.template_size = 0;
  return m;
}

const Pose kInit = makePoseRpy({0, 0, 0.05}, 0, 0, 0);

TEST(Options, DefaultsRangesAndUnknownKeys) {
  const ProgressNodeOptions d = readProgressOptions(node::loadCellFromString(cellYaml()));
  EXPECT_DOUBLE_EQ(d.estimator.eta1, 0.30);
  EXPECT_EQ(d.filter.mode, EtaFilterMode::kMedian);
  const ProgressNodeOptions o =
      readProgressOptions(node::loadCellFromString(cellYaml("{eta_filter: running_max, band_width: 0.01}")));
  EXPECT_EQ(o.filter.mode, EtaFilterMode::kRunningMax);
  EXPECT_DOUBLE_EQ(o.estimator.band_width, 0.01);
  auto error = [](const std::string& section) {
    try {
      readProgressOptions(node::loadCellFromString(cellYaml(section)));
    } catch (const node::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("{band_width: 2}").find("band_width"), std::string::npos);
  EXPECT_NE(error("{eta1: 0.9, eta2: 0.5}").find("eta2"), std::string::npos);
  EXPECT_NE(error("{bandwidth: 0.01}").find("bandwidth"), std::string::npos);
  EXPECT_NE(error("{eta_filter: mean}").find("eta_filter"), std::string::npos);
}

// band_offset (>= -5 mm) and a part's xi (>= 0.5 mm) are each in range, but the band must start
// outside the part: xi + band_offset <= 0 is refused when the options are read, naming the part
// and both values, not by the estimator on every frame (NO_CONTOUR for ever).
TEST(Options, BandOffsetMustKeepEveryPartsBandOutsideIt) {
  auto error = [](const std::string& section, const std::string& xi) {
    try {
      readProgressOptions(node::loadCellFromString(cellYaml(section, xi)));
    } catch (const node::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string e = error("{band_offset: -0.001}", "0.0005");
  EXPECT_NE(e.find("band_offset"), std::string::npos) << e;
  EXPECT_NE(e.find("-0.001"), std::string::npos) << e;
  EXPECT_NE(e.find("'cube'"), std::string::npos) << e;
  EXPECT_NE(e.find("0.0005"), std::string::npos) << e;
  EXPECT_NE(error("{band_offset: -0.0005}", "0.0005"), "");  // xi + band_offset = 0
  EXPECT_EQ(error("{band_offset: -0.0004}", "0.0005"), "");
  EXPECT_EQ(error("{band_offset: -0.005}", "0.01"), "");
}

class NodeTest : public ::testing::Test {
 protected:
  NodeTest() : cell_(node::loadCellFromString(cellYaml())), options_(readProgressOptions(cell_)) {}
  node::CellConfig cell_;
  ProgressNodeOptions options_;
};

TEST_F(NodeTest, PairsEachFrameWithThePoseOfTheSameUtime) {
  ProgressNode n(cell_, options_);
  EXPECT_TRUE(n.onPoints(1000, cubeScene(0.05), 0).empty());  // waits for its pose
  const auto out = n.onPose(poseMsg(1000, kInit));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, 1000);
  EXPECT_EQ(out[0].part, "cube");
  EXPECT_EQ(out[0].status, +progress_t::OK) << out[0].status_reason;
  EXPECT_NEAR(out[0].eta_raw, 0.5, 0.01);  // sampled CAD top within a few mm of the exact 8 cm
  EXPECT_NEAR(out[0].eta, out[0].eta_raw, 1e-12);
  EXPECT_EQ(out[0].phase, +progress_t::PHASE_VACUUM_TRACKED);
  EXPECT_GT(out[0].num_contour, 20);
  EXPECT_EQ(out[0].num_contour, static_cast<int>(out[0].contour.size()));
  EXPECT_GT(out[0].num_band, 100);
  EXPECT_TRUE(n.poll(10'000'000).empty());  // nothing left waiting

  // The pose may also come first.
  EXPECT_TRUE(n.onPose(poseMsg(2000, kInit)).empty());
  EXPECT_EQ(n.onPoints(2000, cubeScene(0.05), 0).size(), 1u);
}

TEST_F(NodeTest, InitialPoseInPhaseOneThenStalePosesGiveNoPose) {
  ProgressNode n(cell_, options_);
  n.onPoints(1000, cubeScene(0.075), 0);
  EXPECT_TRUE(n.poll(100'000).empty());  // still within pose_wait (0.15 s)
  auto out = n.poll(200'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, +progress_t::OK);
  EXPECT_NE(out[0].status_reason.find("initial pose"), std::string::npos);
  EXPECT_NEAR(out[0].eta, (0.08 - 0.075) / 0.06, 0.01);

  // A pose for frame 2000; frame 300000 (0.298 s later) reuses it; frame 900000 is too late.
  const Pose moved = makePoseRpy({0.01, 0, 0.05}, 0, 0, 0);
  n.onPose(poseMsg(2000, moved));
  n.onPoints(300'000, cubeScene(0.05, 0.01), 300'000);
  out = n.poll(500'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, +progress_t::OK);
  EXPECT_NE(out[0].status_reason.find("another frame"), std::string::npos);
  EXPECT_NEAR(out[0].T_cell_part.position[0], 0.01, 1e-9);
  n.onPoints(900'000, cubeScene(0.05, 0.01), 900'000);
  out = n.poll(1'100'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, +progress_t::NO_POSE);
  EXPECT_NE(out[0].status_reason.find("pose_staleness"), std::string::npos);
  EXPECT_EQ(n.stats().no_pose, 1);
}

TEST_F(NodeTest, AFrameTheTrackerSkippedUsesTheNearestPose) {
  ProgressNode n(cell_, options_);
  const Pose later = makePoseRpy({0.01, 0, 0.05}, 0, 0, 0);
  n.onPose(poseMsg(0, kInit));
  n.onPoints(400'000, cubeScene(0.05, 0.01), 0);
  const auto out = n.onPose(poseMsg(450'000, later));  // a newer frame's: this one was skipped
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, 400'000);
  EXPECT_EQ(out[0].status, +progress_t::OK) << out[0].status_reason;
  EXPECT_NE(out[0].status_reason.find("another frame"), std::string::npos);
  EXPECT_NEAR(out[0].T_cell_part.position[0], 0.01, 1e-9);  // 50 ms away, not 400 ms
  EXPECT_TRUE(n.poll(10'000'000).empty());
}

// Under load the tracker skips frames (it tracks the newest); their PROGRESS still goes out in
// time order, before the newer frame's, and not pose_wait later (the planner refuses a PROGRESS
// older than the last one; the eta filter would take the old frame after the new).
TEST_F(NodeTest, SkippedFramesGoOutInTimeOrder) {
  ProgressNode n(cell_, options_);
  for (const std::int64_t u : {1000, 34'000, 67'000, 100'000}) EXPECT_TRUE(n.onPoints(u, cubeScene(0.05), 0).empty());
  auto out = n.onPose(poseMsg(1000, kInit));
  ASSERT_EQ(out.size(), 1u);
  out = n.onPose(poseMsg(100'000, kInit));  // 34000 and 67000 skipped
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].utime, 34'000);
  EXPECT_EQ(out[1].utime, 67'000);
  EXPECT_EQ(out[2].utime, 100'000);
  for (const progress_t& m : out) EXPECT_EQ(m.status, +progress_t::OK) << m.status_reason;
  EXPECT_EQ(out[2].status_reason, "");
  EXPECT_TRUE(n.poll(10'000'000).empty());
  EXPECT_EQ(n.stats().estimates, 4);
}

// A PART_POSE published twice, or a POINTS frame received twice: each (frame, part) is
// estimated once (one PROGRESS, the eta filter fed once, counted once).
TEST_F(NodeTest, EachFrameIsEstimatedOncePerPart) {
  ProgressNode n(cell_, options_);
  // The pose twice, before the frame.
  n.onPose(poseMsg(1000, kInit));
  n.onPose(poseMsg(1000, kInit));
  EXPECT_EQ(n.onPoints(1000, cubeScene(0.05), 0).size(), 1u);
  // The frame twice, before its pose: the second is not used.
  EXPECT_TRUE(n.onPoints(2000, cubeScene(0.05), 0).empty());
  EXPECT_TRUE(n.onPoints(2000, cubeScene(0.05), 0).empty());
  EXPECT_EQ(n.onPose(poseMsg(2000, kInit)).size(), 1u);
  EXPECT_TRUE(n.onPose(poseMsg(2000, kInit)).empty());  // and then the pose twice
  // The frame twice, after its pose.
  n.onPose(poseMsg(3000, kInit));
  EXPECT_EQ(n.onPoints(3000, cubeScene(0.05), 0).size(), 1u);
  EXPECT_TRUE(n.onPoints(3000, cubeScene(0.05), 0).empty());
  EXPECT_TRUE(n.poll(10'000'000).empty());
  EXPECT_EQ(n.stats().estimates, 3);
  EXPECT_EQ(n.stats().frames, 5);
  EXPECT_EQ(n.stats().duplicate_frames, 2);
  EXPECT_NE(n.stats().last_problem.find("POINTS utime 3000 received again"), std::string::npos)
      << n.stats().last_problem;
}

TEST_F(NodeTest, BadInputsAreCountedAndReported) {
  ProgressNode n(cell_, options_);
  part_pose_t bad = poseMsg(1000, kInit);
  bad.T_cell_part.orientation[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(n.onPose(bad).empty());
  EXPECT_EQ(n.stats().invalid_poses, 1);
  EXPECT_TRUE(n.onPose(poseMsg(1000, kInit, "teapot")).empty());
  EXPECT_EQ(n.stats().unknown_parts, 1);

  n.onPoints(5000, {}, 0);
  auto out = n.onPose(poseMsg(5000, kInit));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, +progress_t::NO_POINTS);
  // Heights not computed are NaN, not 0 (what the estimate left when it stopped before them).
  EXPECT_TRUE(std::isnan(out[0].h_max) && std::isnan(out[0].h_min)) << out[0].h_max << " " << out[0].h_min;

  // Powder only far away: no contour, eta held at its previous value.
  n.onPoints(6000, cubeScene(0.05), 0);
  const double held = n.onPose(poseMsg(6000, kInit)).at(0).eta;
  n.onPoints(7000, test::powderPlane(0.03, 0.15, 0.0025, [](double x, double) { return std::abs(x) < 0.1; }), 0);
  out = n.onPose(poseMsg(7000, kInit));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].status, +progress_t::NO_CONTOUR);
  EXPECT_DOUBLE_EQ(out[0].eta, held);
  EXPECT_TRUE(std::isnan(out[0].eta_raw));

  // Stamped outside 0 to 2^53 us (depowder/clock.hpp): a pose is invalid, a frame not used.
  const std::int64_t invalid = n.stats().invalid_poses;
  for (const std::int64_t utime : {std::int64_t{-1}, kMaxUtime + 1, INT64_MIN, INT64_MAX}) {
    EXPECT_TRUE(n.onPose(poseMsg(utime, kInit)).empty());
    EXPECT_NE(n.stats().last_problem.find("utime " + std::to_string(utime)), std::string::npos)
        << n.stats().last_problem;
    EXPECT_TRUE(n.onPoints(utime, cubeScene(0.05), 0).empty());
  }
  EXPECT_EQ(n.stats().invalid_poses, invalid + 4);
  EXPECT_TRUE(n.poll(10'000'000).empty());
}

TEST_F(NodeTest, AirBlastPassLeadsToDone) {
  options_.phase.blast_min_s = 1.0;
  options_.phase.done_frames = 3;
  ProgressNode n(cell_, options_);
  std::int64_t t = 1000;
  auto frame = [&](double h) {
    n.onPoints(t, cubeScene(h), 0);
    const auto out = n.onPose(poseMsg(t, kInit));
    t += 100'000;
    return out.at(0).phase;
  };
  EXPECT_EQ(frame(0.025), +progress_t::PHASE_AIR_BLAST);                              // eta 0.92
  for (int i = 0; i < 20; ++i) EXPECT_EQ(frame(0.02), +progress_t::PHASE_AIR_BLAST);  // no blast yet
  nozzle_plan_t plan;
  plan.utime = t;
  plan.part = "cube";
  plan.phase = progress_t::PHASE_AIR_BLAST;
  plan.num_waypoints = 0;
  n.onPlan(plan);
  int frames = 0;
  while (frame(0.02) != progress_t::PHASE_DONE && frames < 100) ++frames;
  EXPECT_EQ(frames, 10 + 2);  // 1 s of blast at 10 Hz, then 3 frames at the target
}

}  // namespace
}  // namespace depowder::progress
