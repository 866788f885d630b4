// When depowder-monitor ends a run: done for 1 s, and the part at rest (tracked and true poses
// still for 1 s), at most 10 s after DONE.
#include <gtest/gtest.h>

#include "../run_end.hpp"

using namespace depowder;
using depowder::tools::PartEnd;
using depowder::tools::Stillness;

namespace {
constexpr std::int64_t kS = 1000000;
constexpr double kPi = 3.14159265358979323846;
Pose turned(double deg) { return makePoseRpy({0.1, 0.0, 0.05}, 0, 0, deg * kPi / 180); }
}  // namespace

TEST(Stillness, JitterIsStillAMoveIsNot) {
  Stillness s;
  EXPECT_FALSE(s.still(0, 0));
  s.see(turned(0), 0);
  // Frame-to-frame wander of a still part's fit (0.01 deg, 0.6 mm) at 30 Hz for 2 s.
  for (int k = 1; k <= 60; ++k) {
    Pose T = turned(0.01 * (k % 3));
    T.translation().x() += 0.0006 * (k % 2);
    s.see(T, k * kS / 30);
  }
  EXPECT_TRUE(s.still(2 * kS, kS));
  // A turn of 0.6 deg (above 0.5) starts the count again.
  s.see(turned(0.6), 2 * kS + 1);
  EXPECT_FALSE(s.still(2 * kS + kS / 2, kS));
  EXPECT_TRUE(s.still(3 * kS + 1, kS));
  // So does a shift of 2.5 mm.
  Pose shifted = turned(0.6);
  shifted.translation().y() += 0.0025;
  s.see(shifted, 4 * kS);
  EXPECT_FALSE(s.still(4 * kS + kS / 2, kS));
}

TEST(PartEnd, WaitsForTheTrackerToFollowALastSecondMove) {
  PartEnd p;
  p.done_since_us = 10 * kS;
  // Before DONE, and within the first second of DONE: not finished.
  EXPECT_FALSE(p.finished(10 * kS + kS / 2));
  // No pose heard at all (no tracker, no simulator): 1 s of DONE is enough, as before.
  EXPECT_TRUE(p.finished(11 * kS));
  // The part turns 7.5 deg over the second after DONE; the fit follows it 0.5 s later.
  for (int k = 0; k <= 30; ++k) p.truth.see(turned(7.5 * k / 30), 10 * kS + k * kS / 30);
  for (int k = 0; k <= 30; ++k) p.tracked.see(turned(7.5 * k / 30), 10 * kS + kS / 2 + k * kS / 30);
  EXPECT_FALSE(p.finished(11 * kS));          // DONE for 1 s, but still moving
  EXPECT_FALSE(p.finished(12 * kS));          // the truth is still, the fit moved 0.5 s ago
  EXPECT_TRUE(p.finished(12 * kS + kS / 2));  // both still for 1 s
  EXPECT_TRUE(p.atRest(12 * kS + kS / 2));
}

TEST(PartEnd, AFitThatNeverSettlesEndsTenSecondsAfterDone) {
  PartEnd p;
  p.done_since_us = 1;
  for (int k = 0; k <= 600; ++k) p.tracked.see(turned(k % 2 ? 1.0 : 0.0), 1 + k * kS / 30);  // flips 1 deg
  EXPECT_FALSE(p.finished(9 * kS));
  EXPECT_TRUE(p.finished(10 * kS + 1));
  EXPECT_FALSE(p.atRest(10 * kS + 1));
}
