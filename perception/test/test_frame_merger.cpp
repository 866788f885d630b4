// Frame merger: matching by utime, max wait, silent / stale cameras, late and duplicate frames,
// the clock going back, a frame far ahead.
#include <gtest/gtest.h>

#include "depowder/perception/frame_merger.hpp"

using namespace depowder;
using namespace depowder::perception;

namespace {
constexpr std::int64_t kMs = 1000;
constexpr std::int64_t kT0 = 1'700'000'000'000'000;  // some wall-clock epoch, us

CameraFrame frame(const std::string& cam, std::int64_t utime, std::size_t n = 1) {
  return {cam, utime, Cloud(n, Eigen::Vector3d(0, 0, 0.1))};
}

MergerConfig config() {
  MergerConfig c;
  c.match_tolerance = 0.016;
  c.max_wait = 0.040;
  c.silent_after = 1.0;
  c.stale_after = 0.5;
  return c;
}

/// No camera stale or lagging the newest frame.
void expectNoLag(const FrameMerger& m, std::int64_t now) {
  for (const CameraHealth& h : m.health(now)) {
    EXPECT_FALSE(h.stale) << h.name;
    EXPECT_EQ(h.utime_lag, 0) << h.name;
  }
}

/// A one-camera cell at 30 Hz: each step adds LEFT's frame stamped `utime`, polls, and keeps
/// what went out.
struct OneCameraCell {
  FrameMerger m{config(), {"LEFT"}};
  std::int64_t now = kT0;
  std::int64_t period = 33 * kMs;
  std::vector<MergedFrame> out;
  FrameError step(std::int64_t utime) {
    const FrameError e = m.add(frame("LEFT", utime), now);
    for (MergedFrame& f : m.poll(now)) out.push_back(std::move(f));
    now += period;
    return e;
  }
};
}  // namespace

TEST(FrameMerger, TwoCamerasOneTimeStep) {
  FrameMerger m(config(), {"LEFT", "RIGHT"});
  // Both cameras have been seen once (they are expected from then on).
  ASSERT_TRUE(m.add(frame("LEFT", kT0), kT0).ok());
  ASSERT_TRUE(m.add(frame("RIGHT", kT0 + 3 * kMs, 2), kT0 + 1 * kMs).ok());
  auto out = m.poll(kT0 + 1 * kMs);
  ASSERT_EQ(out.size(), 1u);  // both arrived before the first poll
  ASSERT_EQ(out[0].sources.size(), 2u);
  EXPECT_EQ(out[0].sources[0].camera, "LEFT");
  EXPECT_EQ(out[0].sources[1].camera, "RIGHT");
  EXPECT_EQ(out[0].utime, kT0 + 3 * kMs);  // newest source
  EXPECT_TRUE(out[0].missing.empty());
  // Next step: LEFT arrives, RIGHT is expected -> nothing yet; RIGHT arrives -> released at once.
  ASSERT_TRUE(m.add(frame("LEFT", kT0 + 33 * kMs), kT0 + 34 * kMs).ok());
  EXPECT_TRUE(m.poll(kT0 + 34 * kMs).empty());
  EXPECT_EQ(m.nextDeadline(), kT0 + 74 * kMs);
  ASSERT_TRUE(m.add(frame("RIGHT", kT0 + 36 * kMs), kT0 + 37 * kMs).ok());
  out = m.poll(kT0 + 37 * kMs);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].sources.size(), 2u);
  EXPECT_EQ(m.pending(), 0u);
}

TEST(FrameMerger, MissingCameraWaitsAtMostMaxWaitThenStopsBeingWaitedFor) {
  FrameMerger m(config());
  m.add(frame("LEFT", kT0), kT0);
  m.add(frame("RIGHT", kT0), kT0);
  ASSERT_EQ(m.poll(kT0).size(), 1u);
  // RIGHT dies. LEFT's next frame waits max_wait (40 ms), then goes out without RIGHT.
  m.add(frame("LEFT", kT0 + 33 * kMs), kT0 + 33 * kMs);
  EXPECT_TRUE(m.poll(kT0 + 72 * kMs).empty());
  auto out = m.poll(kT0 + 73 * kMs);
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0].sources.size(), 1u);
  EXPECT_EQ(out[0].missing, std::vector<std::string>{"RIGHT"});
  // Once RIGHT has been silent for silent_after (1 s), LEFT's frames go out at once.
  const std::int64_t later = kT0 + 1100 * kMs;
  m.add(frame("LEFT", later), later);
  out = m.poll(later);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].missing.empty());
  const auto health = m.health(later);
  ASSERT_EQ(health.size(), 2u);
  EXPECT_EQ(health[1].name, "RIGHT");
  EXPECT_TRUE(health[1].silent);
  EXPECT_NEAR(health[1].last_seen_age, 1.1, 1e-9);
  EXPECT_FALSE(health[0].silent);
}

TEST(FrameMerger, KnownCameraIsWaitedForAtStartUpOnlyUntilFoundSilent) {
  FrameMerger m(config(), {"LEFT", "RIGHT"});
  // At start-up a known camera is expected even before its first frame...
  m.add(frame("LEFT", kT0), kT0);
  EXPECT_TRUE(m.poll(kT0 + 39 * kMs).empty());
  m.add(frame("RIGHT", kT0 + 1 * kMs), kT0 + 2 * kMs);
  auto out = m.poll(kT0 + 2 * kMs);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].sources.size(), 2u);
  // ... so one that never comes delays frames by max_wait during silent_after, then no more.
  FrameMerger n(config(), {"LEFT", "RIGHT"});
  n.add(frame("LEFT", kT0), kT0);
  EXPECT_TRUE(n.poll(kT0 + 39 * kMs).empty());
  out = n.poll(kT0 + 40 * kMs);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].missing, std::vector<std::string>{"RIGHT"});
  const std::int64_t later = kT0 + 1001 * kMs;
  n.add(frame("LEFT", later), later);
  out = n.poll(later);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].missing.empty());
  const auto health = n.health(later);
  ASSERT_EQ(health.size(), 2u);
  EXPECT_TRUE(health[1].silent);
  EXPECT_EQ(health[1].last_seen_age, -1);
  EXPECT_EQ(health[1].frames, 0);
}

TEST(FrameMerger, UnsynchronisedCamerasPairWithTheClosestFrame) {
  FrameMerger m(config());
  // RIGHT runs 12 ms after LEFT; frames arrive interleaved and out of order.
  m.add(frame("LEFT", kT0), kT0);
  m.add(frame("RIGHT", kT0 + 12 * kMs), kT0 + 13 * kMs);
  ASSERT_EQ(m.poll(kT0 + 13 * kMs).size(), 1u);
  for (int i = 1; i <= 5; ++i) {
    const std::int64_t t = kT0 + i * 33 * kMs;
    ASSERT_TRUE(m.add(frame("LEFT", t), t + kMs).ok());
    ASSERT_TRUE(m.add(frame("RIGHT", t + 12 * kMs), t + 13 * kMs).ok());
  }
  const auto out = m.poll(kT0 + 200 * kMs);
  ASSERT_EQ(out.size(), 5u);
  std::int64_t previous = 0;
  for (const auto& f : out) {
    ASSERT_EQ(f.sources.size(), 2u);
    EXPECT_EQ(f.sources[1].utime - f.sources[0].utime, 12 * kMs);
    EXPECT_GT(f.utime, previous);
    previous = f.utime;
  }
}

TEST(FrameMerger, LateAndDuplicateFramesAreRejected) {
  FrameMerger m(config());
  ASSERT_TRUE(m.add(frame("LEFT", kT0), kT0).ok());
  const FrameError dup = m.add(frame("LEFT", kT0), kT0);
  EXPECT_EQ(dup.status, FrameStatus::kDuplicate);
  ASSERT_EQ(m.poll(kT0).size(), 1u);
  // RIGHT's frame for the released step arrives afterwards: late.
  const FrameError late = m.add(frame("RIGHT", kT0 + 5 * kMs), kT0 + 50 * kMs);
  EXPECT_EQ(late.status, FrameStatus::kLate);
  EXPECT_NE(late.message.find("RIGHT"), std::string::npos);
  // The next step is fine.
  EXPECT_TRUE(m.add(frame("RIGHT", kT0 + 33 * kMs), kT0 + 51 * kMs).ok());
}

TEST(FrameMerger, StaleCameraIsReportedAndNotWaitedFor) {
  // RIGHT's clock is 2 s (or 60 s) behind: its frames are late, it is reported stale, LEFT flows
  // on. It is not the clock going back: LEFT's frames do not.
  for (const std::int64_t lag : {2000 * kMs, 60000 * kMs}) {
    FrameMerger m(config());
    for (int i = 0; i < 10; ++i) {
      const std::int64_t t = kT0 + i * 33 * kMs;
      ASSERT_TRUE(m.add(frame("LEFT", t), t).ok());
      const FrameError e = m.add(frame("RIGHT", t - lag), t + kMs);
      if (i > 0) {
        EXPECT_EQ(e.status, FrameStatus::kLate);
      }
      const auto out = m.poll(t + kMs);
      ASSERT_EQ(out.size(), i == 0 ? 2u : 1u) << i;  // step 0: RIGHT's first frame goes out alone, first
    }
    EXPECT_EQ(m.restarts(), 0);
    const auto health = m.health(kT0 + 400 * kMs);
    ASSERT_EQ(health.size(), 2u);
    EXPECT_TRUE(health[1].stale);
    EXPECT_FALSE(health[1].silent);
    EXPECT_NEAR(health[1].utime_lag, lag * 1e-6, 1e-9);
    EXPECT_FALSE(health[0].stale);
  }
}

TEST(FrameMerger, EveryCameraGoingBackStartsTheTimeStepsOver) {
  // A log played again: both cameras' frames come from 60 s before the last time step published.
  FrameMerger m(config(), {"LEFT", "RIGHT"});
  const std::int64_t first = kT0 + 60000 * kMs;
  std::int64_t now = kT0;
  for (int i = 0; i < 3; ++i, now += 33 * kMs) {
    ASSERT_TRUE(m.add(frame("LEFT", first + i * 33 * kMs), now).ok());
    ASSERT_TRUE(m.add(frame("RIGHT", first + i * 33 * kMs), now).ok());
    ASSERT_EQ(m.poll(now).size(), 1u);
  }
  ASSERT_TRUE(m.add(frame("LEFT", first + 99 * kMs), now).ok());  // waiting for RIGHT's when the clock goes back

  // LEFT goes back first: late, as a camera whose clock runs behind; RIGHT follows: over.
  const FrameError left = m.add(frame("LEFT", kT0), now + kMs);
  EXPECT_EQ(left.status, FrameStatus::kLate);
  EXPECT_EQ(m.restarts(), 0);
  ASSERT_TRUE(m.add(frame("RIGHT", kT0), now + 2 * kMs).ok());
  EXPECT_EQ(m.restarts(), 1);
  EXPECT_NE(m.lastRestart().find("went back 60.1 s"), std::string::npos) << m.lastRestart();

  // The step that was waiting goes out as it was, then the new clock's steps, both cameras in each.
  auto out = m.poll(now + 2 * kMs);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, first + 99 * kMs);
  for (int i = 1; i <= 3; ++i) {
    ASSERT_TRUE(m.add(frame("LEFT", kT0 + i * 33 * kMs), now + i * 33 * kMs).ok()) << i;
    ASSERT_TRUE(m.add(frame("RIGHT", kT0 + i * 33 * kMs), now + i * 33 * kMs).ok()) << i;
  }
  out = m.poll(now + 100 * kMs);
  ASSERT_EQ(out.size(), 4u);  // RIGHT's first alone (LEFT's was late), then three pairs
  EXPECT_EQ(out[0].utime, kT0);
  for (int i = 1; i <= 3; ++i) {
    EXPECT_EQ(out[i].utime, kT0 + i * 33 * kMs);
    EXPECT_EQ(out[i].sources.size(), 2u);
  }
  expectNoLag(m, now + 100 * kMs);
}

TEST(FrameMerger, OneFarPastFrameOfTheOnlyCameraIsABadStampTwoAreARestart) {
  // A one-camera cell: one frame stamped 60 s in the past between good ones is refused as late
  // and changes nothing; two in a row are the clock going back, and the second starts over.
  OneCameraCell c;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(c.step(c.now).ok());
  EXPECT_EQ(c.step(c.now - 60000 * kMs).status, FrameStatus::kLate);
  EXPECT_EQ(c.m.restarts(), 0);
  ASSERT_TRUE(c.step(c.now).ok());  // the next good frame goes out as before
  expectNoLag(c.m, c.now);

  const std::int64_t back = c.now - 60000 * kMs;
  EXPECT_EQ(c.step(back).status, FrameStatus::kLate);
  EXPECT_EQ(c.m.restarts(), 0);
  ASSERT_TRUE(c.step(back + 33 * kMs).ok());  // the second, 59.9 s behind: the new clock's first time step
  EXPECT_EQ(c.m.restarts(), 1);
  EXPECT_NE(c.m.lastRestart().find("went back 59.9 s"), std::string::npos) << c.m.lastRestart();
  c.out.clear();
  const FrameError next = c.step(back + 66 * kMs);
  EXPECT_TRUE(next.ok()) << next.message;
  ASSERT_EQ(c.out.size(), 1u);
  EXPECT_EQ(c.out[0].utime, back + 66 * kMs);
}

// Frames a camera sent from the past before it fell silent do not confirm another camera's one
// far-past frame: that one is a bad stamp (they once made it a restart, and the next good frame
// was then refused as far ahead).
TEST(FrameMerger, ASilentCamerasOldFramesDoNotMakeOneBadStampARestart) {
  FrameMerger m(config(), {"LEFT", "RIGHT"});
  std::int64_t now = kT0;
  auto both = [&](int steps) {
    for (int i = 0; i < steps; ++i, now += 33 * kMs) {
      ASSERT_TRUE(m.add(frame("LEFT", now), now).ok());
      ASSERT_TRUE(m.add(frame("RIGHT", now), now).ok());
      m.poll(now);
    }
  };
  ASSERT_NO_FATAL_FAILURE(both(3));
  // RIGHT restarts with its clock a minute behind, sends three frames and falls silent.
  for (int i = 0; i < 3; ++i, now += 33 * kMs) {
    EXPECT_EQ(m.add(frame("RIGHT", now - 60000 * kMs), now).status, FrameStatus::kLate);
    ASSERT_TRUE(m.add(frame("LEFT", now), now).ok());
    m.poll(now);
  }
  for (int i = 0; i < 45; ++i, now += 33 * kMs) {  // 1.5 s of LEFT alone
    ASSERT_TRUE(m.add(frame("LEFT", now), now).ok());
    m.poll(now);
  }
  EXPECT_EQ(m.add(frame("LEFT", now - 60000 * kMs), now).status, FrameStatus::kLate);
  EXPECT_EQ(m.restarts(), 0) << m.lastRestart();
  now += 33 * kMs;
  const FrameError next = m.add(frame("LEFT", now), now);
  EXPECT_TRUE(next.ok()) << next.message;
}

TEST(FrameMerger, OneFarAheadFrameIsRefusedAndChangesNothing) {
  // LEFT's frame of step 3 stamped a year ahead: refused, and the steps go on as if it had been
  // lost; no camera turns stale, nothing starts over.
  constexpr std::int64_t kYear = 365LL * 24 * 3600 * 1'000'000;
  FrameMerger m(config(), {"LEFT", "RIGHT"});
  std::vector<MergedFrame> out;
  for (int i = 0; i < 6; ++i) {
    const std::int64_t t = kT0 + i * 33 * kMs;
    const FrameError left = m.add(frame("LEFT", i == 3 ? t + kYear : t), t);
    if (i == 3) {
      EXPECT_EQ(left.status, FrameStatus::kAhead);
      EXPECT_NE(left.message.find("31536000.0 s ahead of the newest frame taken and the time since"), std::string::npos)
          << left.message;
    } else {
      EXPECT_TRUE(left.ok()) << i << ": " << left.message;
    }
    ASSERT_TRUE(m.add(frame("RIGHT", t), t + kMs).ok()) << i;
    for (MergedFrame& f : m.poll(t + 30 * kMs)) out.push_back(std::move(f));
  }
  ASSERT_EQ(out.size(), 6u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(out[i].utime, kT0 + i * 33 * kMs) << i;
    EXPECT_EQ(out[i].sources.size(), i == 3 ? 1u : 2u) << i;
  }
  EXPECT_EQ(out[3].missing, std::vector<std::string>{"LEFT"});
  EXPECT_EQ(m.restarts(), 0);
  expectNoLag(m, kT0 + 200 * kMs);
}

TEST(FrameMerger, AClockJumpedForwardIsTakenFromItsSecondFrame) {
  // The only camera's clock jumps 60 s forward: its first frame there is refused, the second,
  // 33 ms after it, confirms the jump and goes out. Two bad stamps in a row far apart confirm
  // nothing.
  OneCameraCell c;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(c.step(c.now).ok());
  EXPECT_EQ(c.step(c.now + 3600000 * kMs).status, FrameStatus::kAhead);
  EXPECT_EQ(c.step(c.now + 7200000 * kMs).status, FrameStatus::kAhead);  // not near the one before

  const std::int64_t jump = 60000 * kMs;
  EXPECT_EQ(c.step(c.now + jump).status, FrameStatus::kAhead);
  const std::int64_t taken = c.now + jump;
  EXPECT_TRUE(c.step(taken).ok());
  EXPECT_TRUE(c.step(c.now + jump).ok());
  ASSERT_EQ(c.out.size(), 5u);
  EXPECT_EQ(c.out[3].utime, taken);
  EXPECT_EQ(c.out[4].utime, taken + 33 * kMs);
  EXPECT_EQ(c.m.restarts(), 0);
  expectNoLag(c.m, c.now);
}

TEST(FrameMerger, FramesFarApartInTimeAreNotAhead) {
  // The only camera sends a frame every 5 s (recorded scans played slowly), then falls silent
  // for 20 s: each frame is far ahead of the one before, but no further than the time between
  // them, and is taken. Its clock then jumps 60 s forward: confirmed by the next frame 5 s on.
  OneCameraCell c;
  c.period = 5000 * kMs;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(c.step(c.now).ok()) << i;
  c.now += 20000 * kMs;
  ASSERT_TRUE(c.step(c.now).ok());
  EXPECT_EQ(c.step(c.now + 60000 * kMs).status, FrameStatus::kAhead);
  const FrameError confirmed = c.step(c.now + 60000 * kMs);
  EXPECT_TRUE(confirmed.ok()) << confirmed.message;
  ASSERT_EQ(c.out.size(), 5u);
  EXPECT_EQ(c.out.back().utime, c.now - c.period + 60000 * kMs);
  EXPECT_EQ(c.m.restarts(), 0);
}
