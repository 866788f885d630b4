// The eta filter and the phase machine, including the toppled pipe (paper Fig. 13d).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "depowder/mesh.hpp"
#include "depowder/parts.hpp"
#include "depowder/progress/phase.hpp"
#include "depowder/progress/progress.hpp"
#include "scenes.hpp"

namespace depowder::progress {
namespace {

constexpr std::int64_t kFrameUs = 33333;  // 30 Hz

EtaFilter filterOf(EtaFilterMode mode) {
  EtaFilterConfig c;
  c.mode = mode;
  return EtaFilter(c);
}

TEST(EtaFilter, MedianIgnoresSingleSpikesBothWays) {
  EtaFilter f = filterOf(EtaFilterMode::kMedian);
  const Pose pose = Pose::Identity();
  for (int i = 0; i < 12; ++i) {
    const double raw = i == 3 ? 0.9 : i == 7 ? 0.1 : 0.5;
    EXPECT_DOUBLE_EQ(f.update(raw, pose), 0.5) << "frame " << i;
  }
}

TEST(EtaFilter, MedianFollowsARealChangeWithinHalfAWindow) {
  EtaFilter f = filterOf(EtaFilterMode::kMedian);
  for (int i = 0; i < 5; ++i) f.update(0.4, Pose::Identity());
  EXPECT_DOUBLE_EQ(f.update(0.6, Pose::Identity()), 0.4);
  EXPECT_DOUBLE_EQ(f.update(0.6, Pose::Identity()), 0.4);
  EXPECT_DOUBLE_EQ(f.update(0.6, Pose::Identity()), 0.6);  // 3 of 5
}

TEST(EtaFilter, RunningMaxLatchesASpike) {
  // The authors' filter: one bad frame holds until the truth catches up.
  EtaFilter f = filterOf(EtaFilterMode::kRunningMax);
  f.update(0.5, Pose::Identity());
  f.update(0.9, Pose::Identity());
  EXPECT_DOUBLE_EQ(f.update(0.5, Pose::Identity()), 0.9);
}

TEST(EtaFilter, NonFiniteInputIsIgnored) {
  EtaFilter f = filterOf(EtaFilterMode::kMedian);
  f.update(0.3, Pose::Identity());
  EXPECT_DOUBLE_EQ(f.update(std::numeric_limits<double>::quiet_NaN(), Pose::Identity()), 0.3);
  Pose bad = Pose::Identity();
  bad.translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_DOUBLE_EQ(f.update(0.8, bad), 0.3);
}

// One glitched PART_POSE (5 cm off) with a wrong eta between correct frames: the jump is not
// confirmed by the next frame, so the filter is not cleared and that eta is not used; the phase
// machine, which never goes back to 1, stays in 1. Two glitches in a row at different poses
// neither. A real jump (two frames at the new pose) is followed at its second frame.
TEST(EtaFilter, AJumpIsFollowedOnlyOnceTheNextFrameConfirmsIt) {
  const Pose at = makePoseRpy({0, 0, 0.05}, 0, 0, 0);
  const Pose glitch = makePoseRpy({0.05, 0, 0.05}, 0, 0, 0);              // 5 cm away
  const Pose glitch2 = makePoseRpy({0, 0, 0.05}, 0, 0, 30 * M_PI / 180);  // 30 deg, and far from `glitch`
  const Pose toppled = makePoseRpy({0.01, 0.04, 0.03}, M_PI / 2, 0, 0);
  for (EtaFilterMode mode : {EtaFilterMode::kMedian, EtaFilterMode::kRunningMaxReset}) {
    SCOPED_TRACE(toString(mode));
    EtaFilter f = filterOf(mode);
    PhaseMachine phase;
    std::int64_t t = 0;
    auto frame = [&](double raw, const Pose& pose) {
      const double eta = f.update(raw, pose);
      phase.update(eta, t += kFrameUs);
      return eta;
    };
    for (int i = 0; i < 6; ++i) frame(0.2, at);
    EXPECT_NEAR(frame(0.95, glitch), 0.2, 1e-12);  // not used
    for (int i = 0; i < 5; ++i) EXPECT_NEAR(frame(0.2, at), 0.2, 1e-12) << "frame " << i << " after the glitch";
    EXPECT_NEAR(frame(0.95, glitch), 0.2, 1e-12);
    EXPECT_NEAR(frame(0.95, glitch2), 0.2, 1e-12);  // far from the first glitch: no confirmation
    EXPECT_NEAR(frame(0.2, at), 0.2, 1e-12);
    EXPECT_EQ(f.resets(), 0);
    EXPECT_EQ(phase.phase(), Phase::kVacuumBuried);

    // The part really fell over: held for one frame, then the new pose's values.
    EXPECT_NEAR(frame(0.6, toppled), 0.2, 1e-12);
    EXPECT_NEAR(frame(0.6, toppled), 0.6, 1e-12);
    EXPECT_EQ(f.resets(), 1);
    EXPECT_EQ(phase.phase(), Phase::kVacuumTracked);
  }
}

TEST(EtaFilter, ParsesModeNames) {
  EtaFilterMode m = EtaFilterMode::kNone;
  EXPECT_TRUE(parseEtaFilterMode("running_max_reset", m));
  EXPECT_EQ(m, EtaFilterMode::kRunningMaxReset);
  EXPECT_FALSE(parseEtaFilterMode("mean", m));
}

// The pipe stands with powder low (eta ~ 0.9), then falls on its side into powder that covers
// half its new 3 cm height. Eq. 2 on the new pose gives ~0.5; the filter must follow, the phase
// must fall back to vacuuming (2), not to "buried at the initial pose" (1).
TEST(Toppled, PipeFilterAndPhaseFollowTheNewHeightRange) {
  const Mesh pipe = parts::pipe();
  const Cloud samples = sampleSurface(pipe, 0.003, 5).points;
  const double half_height = 0.5 * bounds(pipe).sizes().z();
  const Pose standing = makePoseRpy({0, 0, 0.02 + half_height}, 0, 0, 0);
  const double lying_half = 0.5 * bounds(transformed(pipe, makePoseRpy({0, 0, 0}, M_PI / 2, 0, 0))).sizes().z();
  const Pose toppled = makePoseRpy({0.02, 0.03, 0.02 + lying_half}, M_PI / 2, 0, 0);

  auto frame = [&](const Pose& pose, double h, double sigma, unsigned seed) {
    const Cloud cad = transformed(samples, pose);
    Eigen::AlignedBox2d box;
    for (const Point& p : cad) box.extend(p.head<2>());
    box.min().array() -= 0.004;
    box.max().array() += 0.004;
    Cloud scan = test::powderPlane(
        h, 0.15, 0.003,
        [&](double x, double y) {
          if (!box.contains(Eigen::Vector2d(x, y))) return false;
          for (const Point& q : cad)
            if ((q.head<2>() - Eigen::Vector2d(x, y)).squaredNorm() < 0.004 * 0.004) return true;
          return false;
        },
        sigma, seed);
    for (const Point& p : cad)
      if (p.z() >= h) scan.push_back(p);
    const ProgressEstimate e = estimateProgress(cad, scan, 0.008);
    EXPECT_EQ(e.status, Status::kOk) << e.reason;
    return e;
  };

  const ProgressEstimate before = frame(standing, 0.03, 0.0015, 1);
  const ProgressEstimate after = frame(toppled, 0.035, 0.0015, 2);
  const double truth_before = etaFromHeights(0.03, before.h_max, before.h_min);
  const double truth_after = etaFromHeights(0.035, after.h_max, after.h_min);
  ASSERT_GT(truth_before, 0.85);
  ASSERT_NEAR(truth_after, 0.5, 0.05);
  EXPECT_NEAR(before.eta, truth_before, 0.01);
  EXPECT_NEAR(after.eta, truth_after, 0.01);

  EtaFilter median = filterOf(EtaFilterMode::kMedian), max_reset = filterOf(EtaFilterMode::kRunningMaxReset),
            running_max = filterOf(EtaFilterMode::kRunningMax);
  PhaseConfig pc;
  PhaseMachine phase(pc);
  std::int64_t t = 0;
  for (int i = 0; i < 10; ++i, t += kFrameUs) {
    median.update(before.eta, standing);
    max_reset.update(before.eta, standing);
    running_max.update(before.eta, standing);
    phase.update(median.value(), t);
  }
  EXPECT_EQ(phase.phase(), Phase::kAirBlast);
  for (int i = 0; i < 3; ++i, t += kFrameUs) {
    median.update(after.eta, toppled);
    max_reset.update(after.eta, toppled);
    running_max.update(after.eta, toppled);
    phase.update(median.value(), t);
  }
  EXPECT_NEAR(median.value(), truth_after, 0.01);
  EXPECT_NEAR(max_reset.value(), truth_after, 0.01);
  EXPECT_EQ(median.resets(), 1);
  EXPECT_GT(running_max.value() - truth_after, 0.3);  // the authors' filter is stuck at the old value
  EXPECT_EQ(phase.phase(), Phase::kVacuumTracked);
}

TEST(Phase, ThresholdsOfTheWholeRun) {
  PhaseMachine m;  // eta1 0.30, eta2 0.85, done 0.90 after 5 s of blast and 10 frames
  std::int64_t t = 0;
  auto at = [&](double eta) {
    t += kFrameUs;
    return m.update(eta, t);
  };
  EXPECT_EQ(at(0.0), Phase::kVacuumBuried);
  EXPECT_EQ(at(0.30), Phase::kVacuumBuried);  // eta <= eta1
  EXPECT_EQ(at(0.31), Phase::kVacuumTracked);
  EXPECT_EQ(at(0.10), Phase::kVacuumTracked);  // never back to 1
  EXPECT_EQ(at(0.85), Phase::kVacuumTracked);  // eta <= eta2
  EXPECT_EQ(at(0.86), Phase::kAirBlast);
  EXPECT_EQ(at(0.83), Phase::kAirBlast);  // within the hysteresis
  EXPECT_EQ(at(0.81), Phase::kVacuumTracked);
  EXPECT_EQ(at(0.95), Phase::kAirBlast);
  // At the target, but no air blast has been planned: never done.
  for (int i = 0; i < 400; ++i) EXPECT_EQ(at(0.95), Phase::kAirBlast);
  m.airBlastStarted(t);
  const std::int64_t blast = t;
  while (m.phase() != Phase::kDone && t < blast + 20'000'000) at(0.95);
  // Done 5 s after the blast started plus 10 frames at the target (within one frame).
  EXPECT_EQ(m.phase(), Phase::kDone);
  EXPECT_NEAR((t - blast) * 1e-6, 5.0 + 9 * kFrameUs * 1e-6, kFrameUs * 1e-6 + 1e-9);
  EXPECT_EQ(at(0.2), Phase::kDone);  // terminal
}

TEST(Phase, DoneNeedsTheTargetConfirmedAfterTheBlast) {
  PhaseConfig c;
  c.require_blast = false;
  PhaseMachine m(c);
  std::int64_t t = 0;
  m.update(0.88, t);  // phase 3, blast clock starts (no planner needed)
  ASSERT_EQ(m.phase(), Phase::kAirBlast);
  for (int i = 0; i < 600; ++i) m.update(0.88, t += kFrameUs);  // 20 s below the 0.90 target
  EXPECT_EQ(m.phase(), Phase::kAirBlast);
  for (int i = 0; i < 9; ++i) m.update(0.92, t += kFrameUs);
  EXPECT_EQ(m.phase(), Phase::kAirBlast);
  m.update(0.92, t += kFrameUs);
  EXPECT_EQ(m.phase(), Phase::kDone);
}

/// A part entering phase 3 in two frames at 30 Hz; `t` is the last frame's utime.
struct InAirBlast {
  PhaseMachine m;
  std::int64_t t = 0;
  InAirBlast() {
    m.update(0.31, t += kFrameUs);
    m.update(0.95, t += kFrameUs);
  }
  /// Frames at the target until done (20 s of them at most): s from `from` to the frame done.
  double secondsToDone(std::int64_t from) {
    const std::int64_t until = t + 20'000'000;
    while (m.phase() != Phase::kDone && t < until) m.update(0.95, t += kFrameUs);
    return (t - from) * 1e-6;
  }
};
constexpr double kDoneAfter = 5.0 + 9 * kFrameUs * 1e-6;  // blast_min_s, then 10 frames at the target

// An air-blast plan stamped a year ahead (or the frames' clock going back during the blast):
// the blast is timed from the first frame far behind its start, so the part is still done after
// blast_min_s of frames, not a year later.
TEST(Phase, TheBlastIsTimedAnewWhenTheClockGoesBack) {
  InAirBlast b;
  ASSERT_EQ(b.m.phase(), Phase::kAirBlast);
  b.m.airBlastStarted(b.t + 365LL * 24 * 3600 * 1'000'000);
  EXPECT_NEAR(b.secondsToDone(b.t + kFrameUs), kDoneAfter, kFrameUs * 1e-6 + 1e-9);
  EXPECT_EQ(b.m.phase(), Phase::kDone);
}

// The frames' clock jumps 60 s forward 2 s into the blast: the jump is no blasting, so the part
// is done after blast_min_s of frames in all, not at the first frame after it.
TEST(Phase, AGapInTheFramesIsNotTimeBlasted) {
  InAirBlast b;
  ASSERT_EQ(b.m.phase(), Phase::kAirBlast);
  b.m.airBlastStarted(b.t);
  const std::int64_t from = b.t;
  while (b.t < from + 2'000'000) b.m.update(0.95, b.t += kFrameUs);
  const std::int64_t jump = 60'000'000;  // from one frame to the next
  b.t += jump - kFrameUs;
  EXPECT_NEAR(b.secondsToDone(from) - jump * 1e-6, kDoneAfter, kFrameUs * 1e-6 + 1e-9);
  EXPECT_EQ(b.m.phase(), Phase::kDone);
}

}  // namespace
}  // namespace depowder::progress
