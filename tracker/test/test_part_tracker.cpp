// PartTracker (Alg. 1 and its baselines) and MultiTracker on synthetic scenes of the default
// parts buried in powder (bench/scene.hpp), against the ground-truth poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/parts.hpp"
#include "depowder/progress/progress.hpp"
#include "depowder/tracker/multi_tracker.hpp"
#include "depowder/tracker/part_tracker.hpp"
#include "scene.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

double rotErrDeg(const Pose& a, const Pose& b) { return rotationAngle(a.linear(), b.linear()) * 180.0 / M_PI; }
double transErrMm(const Pose& a, const Pose& b) { return translationDistance(a, b) * 1000.0; }
double xiFor(const std::string& part) { return part == "propeller" || part == "pipe" ? 0.008 : 0.01; }

// The tracker defaults, told where the scene's cameras are (as the node does from the cell YAML).
TrackerConfig defaults(Method method = Method::kCu) {
  TrackerConfig c;
  c.method = method;
  for (const scene::Camera& cam : scene::defaultCameras()) c.viewpoints.push_back(cam.T_cell_camera.translation());
  return c;
}

// One part in powder, moving `step_m` along y and `step_deg` in yaw each frame.
struct Sequence {
  Mesh mesh;
  std::vector<Pose> truth;
  std::vector<Cloud> frames;
  Pose T_init;  ///< truth[0] perturbed by 3 mm and 2 deg
};

Sequence makeSequence(const std::string& part, double visibility, int n, double step_m, double step_deg,
                      unsigned seed) {
  Sequence s;
  s.mesh = parts::byName(part);
  std::mt19937 rng(seed);
  const Pose T0 = scene::restingPose(s.mesh, 0.0, -0.02, 0.0, 0.0, 0.4);
  const double powder_z = scene::powderHeightFor(s.mesh, T0, visibility);
  for (int k = 0; k < n; ++k) {
    Pose T = T0;
    T.translation().y() += step_m * k;
    T.linear() = Eigen::AngleAxisd(step_deg * M_PI / 180 * k, Eigen::Vector3d::UnitZ()) * T0.linear();
    s.truth.push_back(T);
    s.frames.push_back(scene::render({{&s.mesh, T}}, powder_z, {}, rng));
  }
  s.T_init = s.truth[0];
  s.T_init.translation() += Eigen::Vector3d(0.002, -0.002, 0.001);  // 3 mm
  s.T_init.linear() = Eigen::AngleAxisd(2.0 * M_PI / 180, Eigen::Vector3d(1, 1, 0).normalized()) * s.T_init.linear();
  return s;
}

// Tracks every frame (none may be lost) and returns the largest `measure` of the results.
template <class Measure>
double worstOver(PartTracker& tracker, const std::vector<Cloud>& frames, Measure measure) {
  double worst = 0;
  for (const Cloud& frame : frames) {
    const TrackResult r = tracker.track(frame);
    EXPECT_NE(r.status, TrackStatus::kLost) << r.reason;
    worst = std::max(worst, measure(r));
  }
  return worst;
}

// Tracks the whole sequence from its true start with `c`; counts in `count` the frames whose
// result has `flag` set and returns the last estimate's rotation error (deg).
double lastRotErr(const Sequence& s, const TrackerConfig& c, bool TrackResult::*flag, int* count) {
  PartTracker tracker("part", s.mesh, s.truth[0], 0.01, c);
  TrackResult r;
  for (const Cloud& frame : s.frames) {
    r = tracker.track(frame);
    *count += r.*flag;
  }
  return rotErrDeg(r.T_cell_part, s.truth.back());
}

class EveryPart : public ::testing::TestWithParam<std::string> {};

// Dug out (100 % visible), pushed 0.5 mm and 0.25 deg a frame, from 3 mm / 2 deg off: every
// frame is tracked and the last estimate is within 5.5 deg / 2 mm of the truth (measured:
// 2.0 deg, 1.0 mm at most). What remains is mostly yaw: the cup's and the owl's spin are seen
// only through the handle and the ears, and the filter weighs each frame's small evidence
// against what it already holds, so they follow with a lag.
TEST_P(EveryPart, TracksFromAPerturbedStart) {
  const std::string part = GetParam();
  const Sequence s = makeSequence(part, 1.0, 10, 0.0005, 0.25, 7);
  PartTracker tracker(part, s.mesh, s.T_init, xiFor(part), defaults());
  TrackResult r;
  for (std::size_t k = 0; k < s.frames.size(); ++k) {
    r = tracker.track(s.frames[k]);
    EXPECT_NE(r.status, TrackStatus::kLost) << part << " frame " << k << ": " << r.reason;
    EXPECT_NE(r.status, TrackStatus::kWaiting) << part << " frame " << k << ": " << r.reason;
    EXPECT_TRUE(isValidPose(r.T_cell_part, 1e-9));
    EXPECT_GT(r.eta, 0.9) << part;
  }
  std::printf("%s: %.2f deg / %.2f mm\n", part.c_str(), rotErrDeg(r.T_cell_part, s.truth.back()),
              transErrMm(r.T_cell_part, s.truth.back()));
  EXPECT_LT(rotErrDeg(r.T_cell_part, s.truth.back()), 5.5) << part;
  EXPECT_LT(transErrMm(r.T_cell_part, s.truth.back()), 2.0) << part;
}

// The cube constrains every direction: at 70 % visible it comes to within 1.5 deg / 2 mm
// (measured 1.15 deg, 1.4 mm).
TEST(PartTracker, CubeAt70PercentIsAccurate) {
  const Sequence s = makeSequence("cube", 0.7, 10, 0.0005, 0.25, 7);
  PartTracker tracker("cube", s.mesh, s.T_init, 0.01, defaults());
  TrackResult r;
  for (const Cloud& frame : s.frames) r = tracker.track(frame);
  EXPECT_EQ(r.status, TrackStatus::kTracking) << r.reason;
  EXPECT_LT(rotErrDeg(r.T_cell_part, s.truth.back()), 1.5);
  EXPECT_LT(transErrMm(r.T_cell_part, s.truth.back()), 2.0);
}

INSTANTIATE_TEST_SUITE_P(DefaultParts, EveryPart, ::testing::Values("cube", "cup", "propeller", "owl", "pipe"));

// Alg. 1, line 11: the eta the tracker acts on is the progress library's Eq. 2 at the tracked
// pose (estimateProgress on P_cad thinned to icp_leaf, over the whole frame) to within 0.5
// percentage points, while the part is pushed and the footprint is reused (measured: 0.08 at most).
TEST(PartTracker, EtaIsEq2AtTheTrackedPose) {
  for (const std::string part : {"owl", "pipe"}) {
    const Sequence s = makeSequence(part, 0.7, 10, 0.0005, 0.25, 7);
    const TrackerConfig config = defaults();
    PartTracker tracker(part, s.mesh, s.T_init, xiFor(part), config);
    const Cloud& cad = tracker.cad().points;
    const Cloud coarse = gather(cad, thinned(cad, allIndices(cad.size()), config.icp_leaf));
    for (const Cloud& frame : s.frames) {
      const TrackResult r = tracker.track(frame);
      ASSERT_EQ(r.status, TrackStatus::kTracking) << part << ": " << r.reason;
      const progress::ProgressEstimate e =
          progress::estimateProgress(transformed(coarse, r.T_cell_part), frame, xiFor(part), config.progress);
      ASSERT_EQ(e.status, progress::Status::kOk) << part << ": " << e.reason;
      EXPECT_NEAR(r.eta, e.eta, 0.005) << part;
    }
  }
}

// Phase 1: while eta <= eta1 no ICP runs and the initial pose is reported unchanged; once the
// powder is down the first frame derives the template (Alg. 1, lines 3-6) and tracks.
TEST(PartTracker, Phase1ReportsTheInitialPose) {
  const Sequence buried = makeSequence("cube", 0.1, 3, 0.0, 0.0, 3);
  PartTracker tracker("cube", buried.mesh, buried.T_init, 0.01, defaults());
  for (const Cloud& frame : buried.frames) {
    const TrackResult r = tracker.track(frame);
    EXPECT_EQ(r.status, TrackStatus::kWaiting);
    EXPECT_NE(r.reason.find("phase 1"), std::string::npos) << r.reason;
    EXPECT_TRUE(r.T_cell_part.isApprox(buried.T_init, 0.0));
    EXPECT_EQ(r.iterations, 0);
    EXPECT_EQ(r.template_size, 0u);
    EXPECT_NEAR(r.eta, 0.1, 0.05);
  }
  EXPECT_FALSE(tracker.started());
  const Sequence dug = makeSequence("cube", 0.7, 1, 0.0, 0.0, 4);
  const TrackResult r = tracker.track(dug.frames[0]);
  EXPECT_EQ(r.status, TrackStatus::kTracking) << r.reason;
  EXPECT_TRUE(r.template_updated);
  EXPECT_EQ(r.template_version, 1);
  EXPECT_GT(r.template_size, 100u);
  EXPECT_GT(r.iterations, 0);
  EXPECT_TRUE(tracker.started());
}

// CU-ICP re-derives the template exactly when Eq. 1 fires: here the part slides 4 mm a frame
// along y (the cameras' view direction), so the translation test fires once the estimate is
// more than delta2 = 5 cm from where the template was last derived.
TEST(PartTracker, CuUpdatesTheTemplateOnlyWhenEq1Fires) {
  const Sequence s = makeSequence("cube", 0.7, 20, 0.004, 0.0, 11);
  PartTracker tracker("cube", s.mesh, s.T_init, 0.01, defaults());
  int updates = 0;
  Pose last_update = s.T_init;
  for (std::size_t k = 0; k < s.frames.size(); ++k) {
    const TrackResult r = tracker.track(s.frames[k]);
    ASSERT_EQ(r.status, TrackStatus::kTracking) << "frame " << k << ": " << r.reason;
    EXPECT_LT(transErrMm(r.T_cell_part, s.truth[k]), 3.0) << "frame " << k;
    if (k == 0) continue;  // the first frame initialises the template (Alg. 1, line 6)
    const double moved = translationDistance(r.T_cell_part, last_update);
    EXPECT_EQ(r.template_updated, moved > 0.05) << "frame " << k << ": moved " << moved;
    EXPECT_EQ(r.template_updated, r.update.update);
    if (r.template_updated) {
      EXPECT_TRUE(r.update.translation);
      last_update = r.T_cell_part;
      ++updates;
    }
  }
  EXPECT_EQ(updates, 1);  // 76 mm in all: one crossing of 50 mm
  EXPECT_EQ(tracker.templateVersion(), 2);
}

// A still part over 300 noisy frames (10 s): the cup's spin about its axis is seen only
// through the handle. Registered frame by frame on its own (filter.data_inflation = 0) the noise
// turns it a little every frame and the turns add up (measured: 3.5 deg at worst); the filter
// carries what earlier frames showed, so the estimate stays put (0.6 deg at worst).
TEST(PartTracker, StillPartDoesNotWanderWithTheNoise) {
  const Sequence s = makeSequence("cup", 0.5, 300, 0.0, 0.0, 21);
  TrackerConfig unfiltered = defaults();
  unfiltered.filter.data_inflation = 0;
  ASSERT_GT(defaults().filter.data_inflation, 0);
  PartTracker filtered("cup", s.mesh, s.truth[0], 0.01, defaults());
  PartTracker alone("cup", s.mesh, s.truth[0], 0.01, unfiltered);
  double worst_filtered = 0, worst_alone = 0;
  for (const Cloud& frame : s.frames) {
    const TrackResult a = filtered.track(frame);
    const TrackResult b = alone.track(frame);
    ASSERT_EQ(a.status, TrackStatus::kTracking) << a.reason;
    worst_filtered = std::max(worst_filtered, rotErrDeg(a.T_cell_part, s.truth[0]));
    worst_alone = std::max(worst_alone, rotErrDeg(b.T_cell_part, s.truth[0]));
  }
  std::printf("still cup, 300 frames: worst rotation error %.2f deg with the filter, %.2f without\n", worst_filtered,
              worst_alone);
  EXPECT_LT(worst_filtered, 2.0);
  EXPECT_LT(worst_filtered, worst_alone);
}

// The disagreement check on a still cup over 120 frames: while its two fits agree it runs every
// check_every-th frame (4), which costs a still part a quarter of the second registration, and
// the estimate is the same as with the check every frame. FilterThatHoldsASpunPartStillStartsAgain
// (below) shows it still restarts a spun part with the default.
TEST(PartTracker, TheCheckRunsEveryFourthFrameWhileAStillPartsFitsAgree) {
  const Sequence s = makeSequence("cup", 0.5, 120, 0.0, 0.0, 23);
  auto run = [&](int check_every, int* checked) {
    TrackerConfig c = defaults();
    c.filter.check_every = check_every;
    return lastRotErr(s, c, &TrackResult::checked, checked);
  };
  int sparse = 0, every = 0;
  ASSERT_EQ(defaults().filter.check_every, 4);
  const double err_sparse = run(4, &sparse), err_every = run(1, &every);
  std::printf("still cup, 120 frames: checked %d frames (%.2f deg) against %d (%.2f deg)\n", sparse, err_sparse, every,
              err_every);
  EXPECT_EQ(every, 120);
  EXPECT_LT(sparse, 45);  // a quarter of 120, and the frames whose fits disagreed
  EXPECT_GT(sparse, 25);
  EXPECT_LT(err_sparse, 2.0);
  EXPECT_NEAR(err_sparse, err_every, 0.5);
}

// A free fit that the status rule doubts says nothing about whether the two fits agree: the
// check runs again the next frame. With every fit doubted (tracking_min_inlier_ratio 0.99; the
// fits match 0.7 to 0.9 of the template) a still cup is checked every frame, not every 4th.
TEST(PartTracker, ADoubtfulFreeFitKeepsTheNextFrameChecked) {
  const Sequence s = makeSequence("cup", 0.5, 40, 0.0, 0.0, 23);
  TrackerConfig c = defaults();
  c.status.tracking_min_inlier_ratio = 0.99;
  int checked = 0;
  const double err = lastRotErr(s, c, &TrackResult::checked, &checked);
  EXPECT_EQ(checked, 40);
  EXPECT_LT(err, 2.0);
}

// Tracks `part`, half-buried, pushed sideways 0.67 mm a frame (2 cm/s at 30 fps) for 10 cm with
// the default settings; `r` is the last frame's result, `truth` the part's pose then.
void trackPushedTenCm(const std::string& part, unsigned seed, TrackResult& r, Pose& truth) {
  const Sequence s = makeSequence(part, 0.5, 150, 0.1 / 150, 0.0, seed);
  PartTracker tracker(part, s.mesh, s.truth[0], 0.01, defaults());
  for (const Cloud& frame : s.frames) {
    r = tracker.track(frame);
    ASSERT_NE(r.status, TrackStatus::kLost) << r.reason;
  }
  truth = s.truth.back();
  std::printf("%s pushed 10 cm: %.2f deg / %.2f mm\n", part.c_str(), rotErrDeg(r.T_cell_part, truth),
              transErrMm(r.T_cell_part, truth));
}

// The half-buried cup pushed sideways 0.67 mm a frame (2 cm/s at 30 fps) for 10 cm: the
// filter's process noise lets a part in powder slide but hardly tip, so the weakly seen roll
// that a slide looks like to the visible band stays put and the estimate slides with the cup
// (measured: 0.6 deg / 1.6 mm at the end; with the motion prior and the hold that the filter
// replaced, 53 deg / 47 mm).
TEST(PartTracker, FollowsAPushedHalfBuriedCup) {
  TrackResult r;
  Pose truth;
  ASSERT_NO_FATAL_FAILURE(trackPushedTenCm("cup", 5, r, truth));
  EXPECT_EQ(r.status, TrackStatus::kTracking) << r.reason;
  EXPECT_LT(rotErrDeg(r.T_cell_part, truth), 3.0);
  EXPECT_LT(transErrMm(r.T_cell_part, truth), 6.0);
}

// The half-buried pipe pushed sideways 10 cm the same way. Its origin (the bounding box's centre)
// is 2 cm off the upright leg that the cameras mostly see; the filter's turns are about the seen
// portion's centre, so the slide is taken as a slide. With the turns about the origin, part of
// the slide went into a spin about the leg that only the elbow shows (measured at the end with a
// pushed part's turn noise of 0.5 deg: 3.4 deg / 2.3 mm; about the origin 8.0 deg / 3.3 mm;
// seeds 7 and 8: 3.0 and 2.8 deg against 6.9 and 7.0). With the default 2 deg, which lets a
// pushed part turn as fast as a turntable spins it, more of the slide goes into the spin: 5.5
// deg / 2.7 mm, seeds 7 to 11 3.9 to 5.8 deg (5.0 and 3.9 to 6.0 with the turn noise opened at
// once, filter.moving_full 1, rather than with the slide).
TEST(PartTracker, FollowsAPushedHalfBuriedPipeWithoutSpinning) {
  TrackResult r;
  Pose truth;
  ASSERT_NO_FATAL_FAILURE(trackPushedTenCm("pipe", 6, r, truth));
  EXPECT_LT(rotErrDeg(r.T_cell_part, truth), 6.5);
  EXPECT_LT(transErrMm(r.T_cell_part, truth), 6.0);
}

// A half-buried cup spun in place at 0.4 deg a frame (12 deg/s at 30 fps, a turntable) from the
// first frame, 48 deg in 120 frames. The filter starts it still, whose turn noise is too small to
// follow: without the disagreement check it holds the cup nearly still while the fits without it
// turn with the handle; with it the filter starts again from what they ask (measured at the last
// frame: 1.3 deg off after 1 restart, 46.6 deg without the check; 17.1 deg after 3 restarts with
// a pushed part's turn noise of 0.5 deg rather than the default 2).
TEST(PartTracker, FilterThatHoldsASpunPartStillStartsAgain) {
  const Sequence s = makeSequence("cup", 0.5, 120, 0.0, 0.4, 31);
  auto lastError = [&](int reset_frames, int* resets) {
    TrackerConfig c = defaults();
    c.filter.reset_frames = reset_frames;
    return lastRotErr(s, c, &TrackResult::reset, resets);
  };
  int resets = 0, none = 0;
  const double with = lastError(defaults().filter.reset_frames, &resets), without = lastError(0, &none);
  std::printf("cup spun 48 deg: %.2f deg off with the check (%d restarts), %.2f without\n", with, resets, without);
  EXPECT_EQ(none, 0);
  EXPECT_GT(resets, 0);
  EXPECT_LT(with, 25.0);
  EXPECT_GT(without, 35.0);
}

// predictMotion (the evaluation's motion oracle): a cup that jumps 1 cm and 15 deg between frames,
// beyond what one frame's ICP can follow, is followed when each jump is predicted (measured:
// 0.45 deg / 0.5 mm at the end), and lost without (110 deg off). A delta that is not a rigid
// motion is refused.
TEST(PartTracker, APredictedMotionIsFollowed) {
  const Sequence s = makeSequence("cup", 0.7, 8, 0.01, 15, 41);
  PartTracker told("cup", s.mesh, s.truth[0], 0.01, defaults()), untold("cup", s.mesh, s.truth[0], 0.01, defaults());
  TrackResult r_told, r_untold;
  for (std::size_t k = 0; k < s.frames.size(); ++k) {
    if (k > 0) told.predictMotion(s.truth[k] * s.truth[k - 1].inverse(Eigen::Isometry));
    r_told = told.track(s.frames[k]);
    r_untold = untold.track(s.frames[k]);
    EXPECT_EQ(r_told.status, TrackStatus::kTracking) << "frame " << k << ": " << r_told.reason;
  }
  const double told_deg = rotErrDeg(r_told.T_cell_part, s.truth.back());
  const double untold_deg = rotErrDeg(r_untold.T_cell_part, s.truth.back());
  std::printf("cup jumping 1 cm and 15 deg a frame: %.2f deg / %.2f mm told, %.2f deg untold\n", told_deg,
              transErrMm(r_told.T_cell_part, s.truth.back()), untold_deg);
  EXPECT_LT(told_deg, 2.0);
  EXPECT_LT(transErrMm(r_told.T_cell_part, s.truth.back()), 2.0);
  EXPECT_GT(untold_deg, 20.0);
  Pose sheared = Pose::Identity();
  sheared.linear()(0, 1) = 0.3;
  EXPECT_THROW(told.predictMotion(sheared), std::invalid_argument);
  Pose nan = Pose::Identity();
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(told.predictMotion(nan), std::invalid_argument);
}

// elapse (the node's dropped frames): a cube 60 % visible, still for 20 frames, then unseen for
// 2 s (60 frame periods: a camera's hiccup) while it is moved 11 mm and turned 10 deg. Told of
// the gap, the filter's first prediction opens by 60 periods of process noise and the first fit
// after it follows the slide (measured: 0.1 and 0.4 mm off, seeds 61 and 62); untold, the filter
// holds the cube near where it was seen last (5.5 and 4.8 mm). The turn, which the filter of a
// still part gives little noise even over 60 periods, is caught by the next frames either way
// (measured at the third frame: 0.3 deg, 0.1 mm both). Periods that are not finite are refused.
TEST(PartTracker, AGapInTheFramesOpensTheFilter) {
  for (const unsigned seed : {61u, 62u}) {
    const Sequence s = makeSequence("cube", 0.6, 20, 0.0, 0.0, seed);
    Pose moved = s.truth[0];
    moved.translation() += Eigen::Vector3d(0.01, 0.005, 0);
    moved.linear() = Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitZ()) * moved.linear();
    std::mt19937 rng(seed);
    const double powder_z = scene::powderHeightFor(s.mesh, s.truth[0], 0.6);
    PartTracker told("cube", s.mesh, s.truth[0], 0.01, defaults()),
        untold("cube", s.mesh, s.truth[0], 0.01, defaults());
    for (const Cloud& frame : s.frames) {
      told.track(frame);
      untold.track(frame);
    }
    told.elapse(60);
    for (int k = 0; k < 3; ++k) {
      const Cloud frame = scene::render({{&s.mesh, moved}}, powder_z, {}, rng);
      const TrackResult a = told.track(frame), b = untold.track(frame);
      std::printf("seed %u, frame %d after the gap: %.2f deg / %.2f mm told, %.2f deg / %.2f mm untold\n", seed, k,
                  rotErrDeg(a.T_cell_part, moved), transErrMm(a.T_cell_part, moved), rotErrDeg(b.T_cell_part, moved),
                  transErrMm(b.T_cell_part, moved));
      if (k == 0) {
        EXPECT_LT(transErrMm(a.T_cell_part, moved), 1.5);
        EXPECT_GT(transErrMm(b.T_cell_part, moved), 3.0);
      }
      if (k == 2)
        for (const TrackResult& r : {a, b}) {
          EXPECT_EQ(r.status, TrackStatus::kTracking) << r.reason;
          EXPECT_LT(rotErrDeg(r.T_cell_part, moved), 1.0);
          EXPECT_LT(transErrMm(r.T_cell_part, moved), 1.0);
        }
    }
  }
  PartTracker tracker("cube", parts::byName("cube"), Pose::Identity(), 0.01, defaults());
  EXPECT_THROW(tracker.elapse(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(tracker.elapse(std::numeric_limits<double>::infinity()), std::invalid_argument);
  EXPECT_NO_THROW(tracker.elapse(0.5));  // counts as 1: a frame sooner than the period
}

// The half-buried cup pushed 2 cm/s (FollowsAPushedHalfBuriedCup) with only every third frame
// tracked, as when the node falls behind the cameras: it is followed to the end either way, told of
// the 3 periods or not; told, the filter lets in more of each fit's noise (measured, seeds 51 to
// 53: worst error along the push 1.5-1.9 deg told, 1.2-1.3 untold; at the end 0.4-0.8 and 0.3-0.5).
TEST(PartTracker, APushedCupTrackedEveryThirdFrameIsFollowed) {
  for (const unsigned seed : {51u, 52u, 53u}) {
    const Sequence s = makeSequence("cup", 0.5, 150, 0.1 / 150, 0.0, seed);
    PartTracker told("cup", s.mesh, s.truth[0], 0.01, defaults()), untold("cup", s.mesh, s.truth[0], 0.01, defaults());
    double worst_told = 0, worst_untold = 0;
    TrackResult a, b;
    std::size_t k = 0;
    for (; k < s.frames.size(); k += 3) {
      if (k > 0) told.elapse(3);
      a = told.track(s.frames[k]);
      b = untold.track(s.frames[k]);
      ASSERT_NE(a.status, TrackStatus::kLost) << "frame " << k << ": " << a.reason;
      worst_told = std::max(worst_told, rotErrDeg(a.T_cell_part, s.truth[k]));
      worst_untold = std::max(worst_untold, rotErrDeg(b.T_cell_part, s.truth[k]));
    }
    const Pose& truth = s.truth[k - 3];
    std::printf(
        "seed %u: worst %.2f deg told, %.2f untold; at the end %.2f deg / %.2f mm told, %.2f deg / %.2f mm untold\n",
        seed, worst_told, worst_untold, rotErrDeg(a.T_cell_part, truth), transErrMm(a.T_cell_part, truth),
        rotErrDeg(b.T_cell_part, truth), transErrMm(b.T_cell_part, truth));
    EXPECT_LT(worst_told, 3.0);
    EXPECT_LT(rotErrDeg(a.T_cell_part, truth), 3.0);
    EXPECT_LT(transErrMm(a.T_cell_part, truth), 6.0);
  }
}

// The motion test judges a speed: the pose against the one tracked moving_frames periods before,
// however many frames were tracked between. A cube creeping 1 mm per 10 periods (half of
// moving_translation) is still, one creeping 3 mm is moving, tracked every frame or every third
// (told so). Counted from frame 45 on, after the initial pose's 3 mm error is gone.
TEST(PartTracker, TheMotionTestJudgesSpeedNotFramesTracked) {
  for (const double step : {0.0001, 0.0003}) {
    const Sequence s = makeSequence("cube", 0.6, 120, step, 0.0, 71);
    for (const int stride : {1, 3}) {
      PartTracker tracker("cube", s.mesh, s.T_init, 0.01, defaults());
      int judged = 0, moving = 0;
      for (std::size_t k = 0; k < s.frames.size(); k += stride) {
        if (k > 0) tracker.elapse(stride);
        const TrackResult r = tracker.track(s.frames[k]);
        ASSERT_NE(r.status, TrackStatus::kLost) << "frame " << k << ": " << r.reason;
        if (k < 45) continue;
        ++judged;
        moving += r.moving ? 1 : 0;
      }
      std::printf("creeping %.1f mm a frame, every %d%s frame: %d of %d frames moving\n", step * 1000, stride,
                  stride == 1 ? "st" : "rd", moving, judged);
      if (step < 0.0002)
        EXPECT_LE(moving, judged / 10);
      else
        EXPECT_GE(moving, judged * 9 / 10);
    }
  }
}

// The default cell's mid-run rise (the pipe's pose rose 1 cm, then turned 13-14 deg): the vacuum
// loop lowers the powder in a ring round the still pipe, where the Eq. 2 band lies, while the
// powder over its horizontal leg stays. The leg's top face, a few mm under that powder, then
// passes the band's powder test, and every powder point over it pulled the template up. Here
// the powder is 1 cm below the leg's cover, which is a slab over the leg's footprint (measured
// over 120 frames: the estimate at most 1.4 mm high with visibility.cover and
// powder_scan_margin, 3.4 mm without them; in the cell the template updates at the raised pose
// fed the rise further).
TEST(PartTracker, StillPipeDoesNotRiseWhenThePowderBesideItIsLowered) {
  const Mesh mesh = parts::byName("pipe");
  const Pose T = scene::restingPose(mesh, 0.0, -0.02, 0.0, 0.0, 0.0);
  // The horizontal leg's top: the upward CAD faces between the base and the origin.
  const SurfaceSamples cad = sampleSurface(transformed(mesh, T), 0.002);
  Eigen::AlignedBox3d leg;
  for (std::size_t i = 0; i < cad.points.size(); ++i)
    if (cad.normals[i].z() > 0.9 && cad.points[i].z() < T.translation().z()) leg.extend(cad.points[i]);
  ASSERT_FALSE(leg.isEmpty());
  const double top = leg.max().z(), cover = top + 0.005, powder_z = cover - 0.01;
  const Eigen::Vector3d lo(leg.min().x(), leg.min().y(), powder_z - 0.001), hi(leg.max().x(), leg.max().y(), cover);
  const Mesh slab = parts::box(hi - lo);
  std::mt19937 rng(9);
  std::vector<Cloud> frames;
  for (int k = 0; k < 120; ++k)
    frames.push_back(scene::render({{&mesh, T}, {&slab, makePoseRpy(0.5 * (lo + hi), 0, 0, 0)}}, powder_z, {}, rng));
  auto worstRise = [&](double cover_test, double scan_margin) {
    TrackerConfig c = defaults();
    c.visibility.cover = cover_test;
    c.visibility.powder_scan_margin = scan_margin;
    PartTracker tracker("pipe", mesh, T, 0.008, c);
    return worstOver(tracker, frames, [&](const TrackResult& r) {
      return 1000 * (r.T_cell_part.translation().z() - T.translation().z());
    });
  };
  const TrackerConfig d = defaults();
  const double rise = worstRise(d.visibility.cover, d.visibility.powder_scan_margin);
  const double rise_before = worstRise(0, 0);
  std::printf("still pipe, leg under 5 mm of powder, 1 cm lower beside: worst rise %.2f mm (without the rules %.2f)\n",
              rise, rise_before);
  EXPECT_GT(rise_before, 2.5);  // the scene shows the rise (else this test would test nothing)
  EXPECT_LT(rise, 2.5);
}

// The default cell's still pipe taken for moving (a recorded run): while the vacuum worked beside
// it, its fit moved 2 mm within 10 frames, the motion test took it for moving, and a pushed
// part's turn noise let its unseen spin go (5.9 deg about the upright leg; the turns kept it
// "moving"). Here the scan shows the still pipe 2.5 mm aside for 20 frames. With the turn noise
// opened at once (filter.moving_full 1) the estimate spins (measured 10.2 deg, 32 frames taken
// for moving; seeds 13-15 8.5 to 10.2 deg); opened with the slide (the default) it does not
// (2.6 deg, 19 frames; seeds 13-15 1.5 to 2.6 deg).
TEST(PartTracker, StillPipeNudgedAsideIsNotGivenAPushedPartsTurns) {
  const Mesh mesh = parts::byName("pipe");
  const Pose T = scene::restingPose(mesh, 0.0, -0.02, 0.0, 0.0, 0.0);
  const double powder_z = scene::powderHeightFor(mesh, T, 0.6);
  std::mt19937 rng(12);
  std::vector<Cloud> frames;
  for (int k = 0; k < 150; ++k) {
    Pose shown = T;
    if (k >= 50 && k < 70) shown.translation().x() += 0.0025;
    frames.push_back(scene::render({{&mesh, shown}}, powder_z, {}, rng));
  }
  auto worstTurn = [&](double moving_full, int* moving) {
    TrackerConfig c = defaults();
    c.filter.moving_full = moving_full;
    PartTracker tracker("pipe", mesh, T, 0.008, c);
    return worstOver(tracker, frames, [&](const TrackResult& r) {
      *moving += r.moving;
      return rotErrDeg(r.T_cell_part, T);
    });
  };
  int at_once_moving = 0, graded_moving = 0;
  const double at_once = worstTurn(1, &at_once_moving);
  const double graded = worstTurn(defaults().filter.moving_full, &graded_moving);
  std::printf(
      "still pipe shown 2.5 mm aside for 20 frames: worst %.2f deg (%d frames moving), %.2f with the turn "
      "noise opened at once (%d)\n",
      graded, graded_moving, at_once, at_once_moving);
  EXPECT_GT(at_once, 6.0);  // the scene shows the spin (else this test would test nothing)
  EXPECT_LT(graded, 4.0);
}

// The toppling pipe (config/scenarios/pipe_topple_cell.yaml): dug out, it tips over the bottom edge
// under the mean of its vertices by 60 deg in 25 frames (accelerating, as it falls), then lies still. A part
// in powder seldom tips, so the filter's tip noise is small (q_tilt_deg) and the filter lags such
// a fall: here it lost the pipe. A falling part's origin sinks; once it sank more than fall_sink
// over moving_frames frames the tip noise is fall_tilt_deg, 1 deg as in that cell (measured:
// worst 13.3 deg, 13 frames into the fall when the gate opened, 0.3 deg at the end; without the
// gate, the default, lost at 41 deg).
TEST(PartTracker, FallingPipeIsFollowed) {
  const Mesh mesh = parts::byName("pipe");
  const Pose T0 = scene::restingPose(mesh, -0.03, 0.0, 0.0, 0.0, 0.0);
  const Eigen::AlignedBox3d box = bounds(transformed(mesh, T0));
  Eigen::Vector3d middle = Eigen::Vector3d::Zero();  // of its vertices
  for (const Eigen::Vector3d& v : mesh.vertices) middle += T0 * v / static_cast<double>(mesh.vertices.size());
  const Eigen::Vector3d pivot(middle.x(), middle.y(), box.min().z());
  const double powder_z = scene::powderHeightFor(mesh, T0, 1.0);
  std::mt19937 rng(21);
  std::vector<Pose> truth;
  std::vector<Cloud> frames;
  for (int k = 0; k < 60; ++k) {
    const double s = std::clamp((k - 10) / 25.0, 0.0, 1.0);
    Pose tip = Pose::Identity();
    tip.linear() = Eigen::AngleAxisd(60.0 * M_PI / 180 * s * s, Eigen::Vector3d::UnitY()).toRotationMatrix();
    tip.translation() = pivot - tip.linear() * pivot;
    truth.push_back(tip * T0);
    frames.push_back(scene::render({{&mesh, truth.back()}}, powder_z, {}, rng));
  }
  struct Run {
    double worst = 0, last = 0;
    TrackStatus status = TrackStatus::kWaiting;
  };
  auto track = [&](double fall_tilt_deg) {
    TrackerConfig c = defaults();
    c.filter.fall_tilt_deg = fall_tilt_deg;
    PartTracker tracker("pipe", mesh, T0, 0.008, c);
    Run run;
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const TrackResult r = tracker.track(frames[k]);
      run.last = rotErrDeg(r.T_cell_part, truth[k]);
      run.worst = std::max(run.worst, run.last);
      run.status = r.status;
    }
    return run;
  };
  ASSERT_EQ(defaults().filter.fall_tilt_deg, 0);
  const Run with = track(1.0), without = track(defaults().filter.fall_tilt_deg);
  std::printf("pipe tipped 60 deg in 25 frames: worst %.2f deg, last %.2f; without the gate %.2f, last %.2f (%s)\n",
              with.worst, with.last, without.worst, without.last, toString(without.status));
  EXPECT_EQ(with.status, TrackStatus::kTracking);
  EXPECT_LT(with.worst, 18.0);
  EXPECT_LT(with.last, 2.0);
  EXPECT_GT(without.last, 20.0);  // the fall is one the filter cannot follow without the gate
}

// The refit (TrackerConfig::refit_margin): the dug-out pipe (eta 1) with the tracker's pose
// turned 30 deg about its upright leg, as after a fall. Alg. 2 at that pose leaves the elbow's
// leg out of the template, the filter keeps the turn, and ICP alone stays wrong (measured:
// 29.4 deg after 15 frames); the refit fits P_cad again where the cameras look and comes back to
// within 4 deg (measured 1.1 deg, one refit).
TEST(PartTracker, RefitRecoversAWrongPoseOfADugOutPart) {
  const Sequence s = makeSequence("pipe", 1.0, 15, 0.0, 0.0, 11);
  Pose T_wrong = s.truth[0];
  T_wrong.linear() = s.truth[0].linear() * Eigen::AngleAxisd(30.0 * M_PI / 180, Eigen::Vector3d::UnitZ());
  // The refit alone: the disagreement check also mends this pose, more slowly (measured: 4.5 deg
  // after the 15 frames).
  TrackerConfig refit = defaults();
  refit.filter.reset_frames = 0;
  TrackerConfig no_refit = refit;
  no_refit.refit_margin = 0;
  ASSERT_GT(defaults().refit_margin, 0);
  PartTracker with("pipe", s.mesh, T_wrong, 0.008, refit);
  PartTracker without("pipe", s.mesh, T_wrong, 0.008, no_refit);
  TrackResult a, b;
  int refits = 0;
  for (const Cloud& frame : s.frames) {
    a = with.track(frame);
    b = without.track(frame);
    refits += a.refit;
    EXPECT_FALSE(b.refit);
  }
  const double err_with = rotErrDeg(a.T_cell_part, s.truth.back());
  const double err_without = rotErrDeg(b.T_cell_part, s.truth.back());
  std::printf("pipe 30 deg off: %.2f deg with the refit (%d refits), %.2f deg without\n", err_with, refits,
              err_without);
  EXPECT_EQ(a.status, TrackStatus::kTracking) << a.reason;
  EXPECT_GE(refits, 1);
  EXPECT_LT(err_with, 4.0);
  EXPECT_GT(err_without, 15.0);
}

// A refit on a frame whose ICP fit was doubtful (DEGRADED: here every fit is, by a residual
// limit no fit meets) derives the template again at the refitted pose, as on any other frame:
// the template of the wrong pose, kept, lacks the points that hold the refitted pose. The pipe
// (eta 1) is tracked still for 5 frames, then turned 30 deg at once about the vertical, as by a
// fall.
TEST(PartTracker, ARefitOnADoubtfulFrameDerivesTheTemplateAgain) {
  Sequence s = makeSequence("pipe", 1.0, 5, 0.0, 0.0, 11);
  Pose T_turned = s.truth[0];
  T_turned.linear() = Eigen::AngleAxisd(30.0 * M_PI / 180, Eigen::Vector3d::UnitZ()) * s.truth[0].linear();
  const double powder_z = scene::powderHeightFor(s.mesh, s.truth[0], 1.0);
  std::mt19937 rng(12);
  for (int k = 0; k < 10; ++k) s.frames.push_back(scene::render({{&s.mesh, T_turned}}, powder_z, {}, rng));
  TrackerConfig config = defaults();
  config.filter.reset_frames = 0;
  config.status.tracking_max_rms = 1e-6;
  PartTracker tracker("pipe", s.mesh, s.truth[0], 0.008, config);
  int refits = 0;
  TrackResult r;
  for (std::size_t k = 0; k < s.frames.size(); ++k) {
    r = tracker.track(s.frames[k]);
    if (!r.refit) continue;
    ++refits;
    EXPECT_GE(k, 5u);
    EXPECT_EQ(r.status, TrackStatus::kDegraded) << r.reason;
    EXPECT_TRUE(r.template_updated) << "frame " << k;
  }
  std::printf("pipe turned 30 deg at once: %d refits, last %.2f deg off\n", refits, rotErrDeg(r.T_cell_part, T_turned));
  EXPECT_GE(refits, 1);
  EXPECT_LT(rotErrDeg(r.T_cell_part, T_turned), 4.0);
}

// The refit runs on the frames the disagreement check is due (every frame while the part moves
// or its fits disagree, every check_every-th while a still part's fits agree), and every frame
// without the check. A still, dug-out pipe tracked from its true pose: lines of sight judged only
// on checked frames, and some frames not checked; the same pipe 30 deg off is still mended.
TEST(PartTracker, RefitRunsWhenTheCheckIsDue) {
  const Sequence s = makeSequence("pipe", 1.0, 16, 0.0, 0.0, 11);
  auto judged = [](const TrackResult& r) { return r.sight.total() > 0; };
  PartTracker still("pipe", s.mesh, s.truth[0], 0.008, defaults());
  int checked = 0, refit_frames = 0;
  for (const Cloud& frame : s.frames) {
    const TrackResult r = still.track(frame);
    ASSERT_EQ(r.status, TrackStatus::kTracking) << r.reason;
    EXPECT_EQ(judged(r), r.checked);  // eta 1 >= refit_min_eta: judged exactly when checked
    checked += r.checked;
    refit_frames += judged(r);
  }
  std::printf("still pipe, 16 frames: checked and refit-judged on %d, %d\n", checked, refit_frames);
  EXPECT_GE(checked, 16 / defaults().filter.check_every);
  EXPECT_LT(checked, 16);  // the gate skips some frames
  TrackerConfig no_check = defaults();
  no_check.filter.reset_frames = 0;
  PartTracker unchecked("pipe", s.mesh, s.truth[0], 0.008, no_check);
  for (const Cloud& frame : s.frames) EXPECT_TRUE(judged(unchecked.track(frame)));

  Pose T_wrong = s.truth[0];
  T_wrong.linear() = s.truth[0].linear() * Eigen::AngleAxisd(30.0 * M_PI / 180, Eigen::Vector3d::UnitZ());
  PartTracker wrong("pipe", s.mesh, T_wrong, 0.008, defaults());
  TrackResult last;
  int refits = 0;
  for (const Cloud& frame : s.frames) refits += (last = wrong.track(frame)).refit;
  const double err = rotErrDeg(last.T_cell_part, s.truth.back());
  std::printf("pipe 30 deg off, the check on: %.2f deg after 16 frames (%d refits)\n", err, refits);
  EXPECT_GE(refits, 1);
  EXPECT_LT(err, 4.0);
}

// The methods differ only in the update policy: CU-ICP with thresholds too small to miss any
// change reproduces Continuous ICP bit for bit, and Vanilla ICP keeps the whole CAD model.
TEST(PartTracker, MethodsDifferOnlyInTheUpdatePolicy) {
  const Sequence s = makeSequence("owl", 0.6, 8, 0.001, 0.5, 5);
  TrackerConfig cu0 = defaults(Method::kCu);
  cu0.delta1_deg = 1e-12;
  cu0.delta2 = 1e-15;
  cu0.delta3 = 1e-15;
  PartTracker cu("owl", s.mesh, s.T_init, 0.01, cu0);
  PartTracker continuous("owl", s.mesh, s.T_init, 0.01, defaults(Method::kContinuous));
  PartTracker vanilla("owl", s.mesh, s.T_init, 0.01, defaults(Method::kVanilla));
  for (std::size_t k = 0; k < s.frames.size(); ++k) {
    const TrackResult a = cu.track(s.frames[k]);
    const TrackResult b = continuous.track(s.frames[k]);
    const TrackResult v = vanilla.track(s.frames[k]);
    EXPECT_EQ(a.T_cell_part.matrix(), b.T_cell_part.matrix()) << "frame " << k;
    EXPECT_EQ(a.template_size, b.template_size);
    EXPECT_EQ(a.template_version, b.template_version);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_TRUE(b.template_updated);
    EXPECT_EQ(v.template_size, vanilla.cad().points.size());
    EXPECT_EQ(v.template_version, 1);
    EXPECT_EQ(v.template_updated, k == 0);
  }
  EXPECT_EQ(cu.templateIndices(), continuous.templateIndices());
}

// Bad frames: a clear reason, the last good pose kept, and tracking resumes afterwards.
TEST(PartTracker, BadFramesKeepTheLastGoodPose) {
  const Sequence s = makeSequence("pipe", 0.7, 3, 0.0, 0.0, 9);
  PartTracker tracker("pipe", s.mesh, s.T_init, 0.008, defaults());

  TrackResult r = tracker.track({});  // before tracking started: still waiting
  EXPECT_EQ(r.status, TrackStatus::kWaiting);
  EXPECT_NE(r.reason.find("empty scan"), std::string::npos) << r.reason;
  EXPECT_TRUE(r.T_cell_part.isApprox(s.T_init, 0.0));

  const TrackResult good = tracker.track(s.frames[0]);
  ASSERT_EQ(good.status, TrackStatus::kTracking) << good.reason;

  auto expectKept = [&](const TrackResult& bad, const std::string& why) {
    EXPECT_EQ(bad.status, TrackStatus::kLost);
    EXPECT_NE(bad.reason.find(why), std::string::npos) << bad.reason;
    EXPECT_NE(bad.reason.find("last good pose kept"), std::string::npos) << bad.reason;
    EXPECT_TRUE(bad.T_cell_part.isApprox(good.T_cell_part, 0.0));
    EXPECT_TRUE(isValidPose(bad.T_cell_part, 1e-9));
  };
  expectKept(tracker.track({}), "empty scan");
  Cloud with_nan = s.frames[1];
  with_nan[with_nan.size() / 2].y() = std::numeric_limits<double>::quiet_NaN();
  with_nan.back().z() = std::numeric_limits<double>::infinity();
  expectKept(tracker.track(with_nan), "2 of");
  expectKept(tracker.track(with_nan), "NaN or infinite");
  const Cloud far = transformed(s.frames[1], makePoseRpy({0.5, 0, 0}, 0, 0, 0));  // 50 cm away
  expectKept(tracker.track(far), "scan points within");
  const Cloud few(s.frames[1].begin(), s.frames[1].begin() + 5);
  EXPECT_EQ(tracker.track(few).status, TrackStatus::kLost);

  r = tracker.track(s.frames[2]);
  EXPECT_EQ(r.status, TrackStatus::kTracking) << r.reason;
  EXPECT_LT(transErrMm(r.T_cell_part, s.truth[2]), 3.0);
}

// Clutter with no part in it never gives a NaN or non-orthonormal pose, whatever the status.
TEST(PartTracker, ClutterNeverGivesAnInvalidPose) {
  const Sequence s = makeSequence("cup", 0.7, 1, 0.0, 0.0, 2);
  PartTracker tracker("cup", s.mesh, s.T_init, 0.01, defaults());
  ASSERT_EQ(tracker.track(s.frames[0]).status, TrackStatus::kTracking);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.08, 0.08);
  for (int k = 0; k < 5; ++k) {
    Cloud clutter;
    for (int i = 0; i < 3000; ++i) clutter.push_back(s.T_init.translation() + Point(u(rng), u(rng), u(rng)));
    const TrackResult r = tracker.track(clutter);
    EXPECT_TRUE(isValidPose(r.T_cell_part, 1e-9));
    EXPECT_TRUE(r.T_cell_part.matrix().allFinite());
    if (r.status == TrackStatus::kTracking)
      EXPECT_TRUE(r.reason.empty());
    else
      EXPECT_FALSE(r.reason.empty());
  }
}

TEST(PartTracker, ConstructorRejectsBadPartsAndConfigs) {
  const Mesh cube = parts::byName("cube");
  auto message = [&](auto&& make) {
    try {
      make();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  const std::string no_triangles = message([&] { PartTracker("empty", Mesh{}, Pose::Identity(), 0.01); });
  EXPECT_NE(no_triangles.find("part 'empty'"), std::string::npos) << no_triangles;
  EXPECT_NE(no_triangles.find("no triangles"), std::string::npos) << no_triangles;
  Mesh flat;  // triangles with no area
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.triangles = {{0, 1, 2}};
  EXPECT_NE(message([&] { PartTracker("flat", flat, Pose::Identity(), 0.01); }).find("part 'flat'"), std::string::npos);
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.0); }).find("xi"), std::string::npos);
  Pose bad = Pose::Identity();
  bad.linear()(0, 0) = 2;
  EXPECT_NE(message([&] { PartTracker("cube", cube, bad, 0.01); }).find("initial pose"), std::string::npos);
  TrackerConfig c;
  c.delta2 = -1;
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, c); }).find("delta2"), std::string::npos);
  TrackerConfig f;
  f.filter.q_tilt_deg = 0;  // would make the predicted information singular
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, f); }).find("q_tilt_deg"),
            std::string::npos);
  TrackerConfig ramp;
  ramp.filter.moving_full = 0.5;  // the turn noise would be fully open below the motion threshold
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, ramp); }).find("moving_full"),
            std::string::npos);
  TrackerConfig margin;
  margin.filter.reset_inlier_margin = std::nan("");
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, margin); }).find("reset_inlier_margin"),
            std::string::npos);
  TrackerConfig unexplained;
  unexplained.filter.reset_unexplained = 1.5;
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, unexplained); }).find("reset_unexplained"),
            std::string::npos);
  TrackerConfig fall;
  fall.filter.fall_tilt_deg = -1;
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, fall); }).find("fall_tilt_deg"),
            std::string::npos);
  fall = TrackerConfig{};
  fall.filter.fall_sink = 0;  // every part would be falling
  EXPECT_NE(message([&] { PartTracker("cube", cube, Pose::Identity(), 0.01, fall); }).find("fall_sink"),
            std::string::npos);
}

// Several parts in one cell, tracked in parallel: the same results on 1 and 2 threads, each
// part within tolerance of its truth.
TEST(MultiTracker, ParallelMatchesSerial) {
  const std::vector<std::string> names{"cube", "owl", "pipe"};
  std::vector<Mesh> meshes;
  for (const std::string& n : names) meshes.push_back(parts::byName(n));
  const std::vector<Pose> truth{scene::restingPose(meshes[0], -0.11, 0.05, 0, 0, 0.3),
                                scene::restingPose(meshes[1], 0.0, -0.06, 0, 0, -0.5),
                                scene::restingPose(meshes[2], 0.11, 0.04, 0, 0, 1.0)};
  std::vector<scene::Placed> placed;
  for (std::size_t i = 0; i < names.size(); ++i) placed.push_back({&meshes[i], truth[i]});
  std::mt19937 rng(23);
  std::vector<Cloud> frames;
  for (int k = 0; k < 4; ++k) frames.push_back(scene::render(placed, 0.025, {}, rng));

  auto makeTrackers = [&] {
    std::vector<PartTracker> out;
    for (std::size_t i = 0; i < names.size(); ++i) {
      Pose init = truth[i];
      init.translation() += Eigen::Vector3d(0.002, 0.001, -0.001);
      out.emplace_back(names[i], meshes[i], init, xiFor(names[i]), defaults());
    }
    return out;
  };
  MultiTracker serial(makeTrackers(), 1), parallel(makeTrackers(), 2);
  EXPECT_EQ(serial.threads(), 1);
  EXPECT_LE(parallel.threads(), 2);
  EXPECT_LE(MultiTracker(makeTrackers(), 0).threads(), static_cast<int>(names.size()));
  for (const Cloud& frame : frames) {
    const std::vector<TrackResult> a = serial.track(frame), b = parallel.track(frame);
    ASSERT_EQ(a.size(), names.size());
    ASSERT_EQ(b.size(), names.size());
    for (std::size_t i = 0; i < names.size(); ++i) {
      EXPECT_EQ(a[i].T_cell_part.matrix(), b[i].T_cell_part.matrix()) << names[i];
      EXPECT_EQ(a[i].status, TrackStatus::kTracking) << names[i] << ": " << a[i].reason;
    }
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    EXPECT_LT(rotErrDeg(serial.part(i).pose(), truth[i]), 2.0) << names[i];
    EXPECT_LT(transErrMm(serial.part(i).pose(), truth[i]), 2.5) << names[i];
  }
}

}  // namespace
