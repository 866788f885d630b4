// The steps of a recording host's clock taken out of a log's event times (log_time.hpp,
// depowder-logmend): on a simulated recording whose logger clock steps an hour back and, 10 s
// later, forward again, with a real silence of the whole cell after that; and on the golden log,
// which has no step (one event recorded 114 us before the one before it, as lcm-logger can) and
// must come out byte for byte as it went in.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/log_time.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/test_messages.hpp"

namespace {

using namespace depowder;
using node::HeartbeatMark;
using node::LogGap;

constexpr std::int64_t kS = 1'000'000;  // us
constexpr std::int64_t kHour = 3600 * kS;
constexpr std::int64_t kBack = 10 * kS;                           // the logger's clock an hour back at 10 s
constexpr std::int64_t kForward = 20 * kS;                        // and forward again at 20 s
constexpr std::int64_t kQuietFrom = 28 * kS, kQuietTo = 31 * kS;  // nothing sent: a silence
constexpr std::int64_t kEnd = 40 * kS;

/// A recording: each event's true arrival time, its time as the logger's clock recorded it, and
/// the heartbeats among them. Two cameras at 30 Hz and three processes' heartbeats at 2 Hz, each
/// message 0 to 3 ms on its way (seeded).
struct Recording {
  std::vector<std::int64_t> arrival, recorded;
  std::vector<HeartbeatMark> heartbeats;
  std::vector<std::string> process;  ///< "" for a camera frame
};

Recording simulate() {
  struct Sent {
    std::int64_t arrival;
    std::string process;
    std::int64_t uptime;
  };
  std::vector<Sent> sent;
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::int64_t> latency(0, 3000);
  auto quiet = [](std::int64_t t) { return t >= kQuietFrom && t < kQuietTo; };
  for (std::int64_t t = 0; t < kEnd; t += kS / 30)
    for (int camera = 0; camera < 2; ++camera)
      if (!quiet(t)) sent.push_back({t + latency(rng), "", 0});
  const char* processes[] = {"depowder-tracker", "depowder-planner", "depowder-driver"};
  for (int p = 0; p < 3; ++p)
    for (std::int64_t t = p * kS / 6; t < kEnd; t += kS / 2)  // each started p * 5 s before the log
      if (!quiet(t)) sent.push_back({t + latency(rng), processes[p], t + p * 5 * kS});
  std::sort(sent.begin(), sent.end(), [](const Sent& a, const Sent& b) { return a.arrival < b.arrival; });
  Recording r;
  const std::int64_t epoch = 1'795'000'000 * kS;  // late 2026
  for (const Sent& s : sent) {
    if (!s.process.empty()) r.heartbeats.push_back({r.arrival.size(), s.process, s.uptime});
    r.arrival.push_back(s.arrival);
    r.recorded.push_back(epoch + s.arrival - (s.arrival >= kBack && s.arrival < kForward ? kHour : 0));
    r.process.push_back(s.process);
  }
  return r;
}

/// The largest difference between the times along the log (from its first event) of `mended`
/// and of the true arrivals, us.
std::int64_t worstError(const std::vector<std::int64_t>& mended, const std::vector<std::int64_t>& arrival) {
  std::int64_t worst = 0;
  for (std::size_t i = 0; i < mended.size(); ++i)
    worst = std::max<std::int64_t>(worst, std::llabs((mended[i] - mended[0]) - (arrival[i] - arrival[0])));
  return worst;
}

TEST(MendTimes, HeartbeatsTellTheStepsFromTheSilence) {
  const Recording r = simulate();
  const node::LogTimes times = node::mendTimes(r.recorded, r.heartbeats);
  ASSERT_EQ(times.gaps.size(), 3u);
  const LogGap& back = times.gaps[0];
  const LogGap& forward = times.gaps[1];
  const LogGap& silence = times.gaps[2];
  EXPECT_EQ(back.kind, LogGap::kStep);
  EXPECT_EQ(forward.kind, LogGap::kStep);
  EXPECT_EQ(silence.kind, LogGap::kSilence);
  EXPECT_EQ(times.steps(), 2u);
  // Each step to within the messages' 3 ms of latency; the silence kept as recorded.
  EXPECT_NEAR(back.recorded_us - back.mended_us, -kHour, 6000);
  EXPECT_NEAR(forward.recorded_us - forward.mended_us, kHour, 6000);
  EXPECT_EQ(silence.mended_us, silence.recorded_us);
  EXPECT_NEAR(silence.recorded_us, kQuietTo - kQuietFrom, 40000);
  EXPECT_NEAR(r.arrival[back.event], kBack, 40000);
  EXPECT_NEAR(r.arrival[forward.event], kForward, 40000);
  EXPECT_FALSE(back.told_by.empty());
  EXPECT_LT(worstError(times.utime, r.arrival), 6000);
  EXPECT_NE(times.describe(back).find("clock stepped -3600.0"), std::string::npos) << times.describe(back);
  EXPECT_NE(times.describe(silence).find("a silence, as the heartbeats of"), std::string::npos)
      << times.describe(silence);
}

TEST(MendTimes, WithoutUptimeAStepBackCountsNoTimeAndLongGapsAreKept) {
  // Heartbeats recorded before they carried uptime_s tell nothing.
  const Recording r = simulate();
  const node::LogTimes times = node::mendTimes(r.recorded, {});
  ASSERT_EQ(times.gaps.size(), 3u);
  EXPECT_EQ(times.gaps[0].kind, LogGap::kStep);
  EXPECT_EQ(times.gaps[0].mended_us, 0);
  EXPECT_TRUE(times.gaps[0].told_by.empty());
  EXPECT_EQ(times.gaps[1].kind, LogGap::kUnexplained);
  EXPECT_EQ(times.gaps[2].kind, LogGap::kUnexplained);
  EXPECT_TRUE(std::is_sorted(times.utime.begin(), times.utime.end()));
  // Up to the forward step, off by the one gap the step back took (at most a frame apart).
  const std::vector<std::int64_t> before(times.utime.begin(), times.utime.begin() + times.gaps[1].event);
  EXPECT_LT(worstError(before, r.arrival), 40000);
}

TEST(MendTimes, ALogWithoutAStepKeepsItsTimesExactly) {
  Recording r = simulate();
  for (std::size_t i = 0; i < r.recorded.size(); ++i) r.recorded[i] = r.arrival[i] + 1'795'000'000 * kS;
  const node::LogTimes times = node::mendTimes(r.recorded, r.heartbeats);
  EXPECT_EQ(times.utime, r.recorded);
  ASSERT_EQ(times.gaps.size(), 1u);
  EXPECT_EQ(times.gaps[0].kind, LogGap::kSilence);
  EXPECT_TRUE(node::mendTimes({}, {}).utime.empty());
}

class Logmend : public ::testing::Test {
 protected:
  std::string path(const std::string& file) const { return tool_.dir() + "/" + file; }
  int run(const std::vector<std::string>& args, std::string* out) const { return tool_.run(args, out); }
  /// `r` as an LCM log: the heartbeats as heartbeat_t with their uptime_s, the frames as bytes.
  void write(const Recording& r, const std::string& file) const {
    lcm::LogFile log(file, "w");
    ASSERT_TRUE(log.good()) << file;
    for (std::size_t i = 0; i < r.recorded.size(); ++i) {
      if (r.process[i].empty()) {
        ASSERT_EQ(testutil::writeBytes(log, "POINTS", std::vector<std::uint8_t>(64, 0x5a), r.recorded[i]), 0);
        continue;
      }
      const auto mark =
          std::find_if(r.heartbeats.begin(), r.heartbeats.end(), [&](const HeartbeatMark& h) { return h.event == i; });
      heartbeat_t h{};
      h.process = r.process[i];
      h.host = "cell";
      h.pid = 100;
      h.stat_names = {"uptime_s"};
      h.stat_values = {mark->uptime_us * 1e-6};
      h.num_stats = 1;
      ASSERT_EQ(testutil::writeMessage(log, "HEARTBEAT", h, r.recorded[i]), 0);
    }
  }
  static std::vector<std::int64_t> eventTimes(const std::string& file) {
    lcm::LogFile log(file, "r");
    std::vector<std::int64_t> t;
    for (const lcm::LogEvent* e = log.good() ? log.readNextEvent() : nullptr; e; e = log.readNextEvent())
      t.push_back(e->timestamp);
    return t;
  }
  static bool sameBytes(const std::string& a, const std::string& b) {
    std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
    return fa && fb &&
           std::equal(std::istreambuf_iterator<char>(fa), std::istreambuf_iterator<char>(),
                      std::istreambuf_iterator<char>(fb), std::istreambuf_iterator<char>());
  }
  testutil::ProcessUnderTest tool_{"depowder-logmend"};  // its executable and a scratch directory
};

TEST_F(Logmend, WritesTheLogWithTheStepsTakenOut) {
  const Recording r = simulate();
  write(r, path("stepped.lcmlog"));
  std::string out;
  ASSERT_EQ(run({path("stepped.lcmlog"), path("mended.lcmlog")}, &out), 0) << out;
  EXPECT_NE(out.find("clock stepped -3600.0"), std::string::npos) << out;
  EXPECT_NE(out.find("clock stepped +3600.0"), std::string::npos) << out;
  EXPECT_NE(out.find(std::to_string(r.arrival.size()) + " events, 2 steps of the clock taken out"), std::string::npos)
      << out;
  const std::vector<std::int64_t> mended = eventTimes(path("mended.lcmlog"));
  ASSERT_EQ(mended.size(), r.arrival.size());
  EXPECT_LT(worstError(mended, r.arrival), 6000);
  EXPECT_EQ(eventTimes(path("stepped.lcmlog")), r.recorded);  // the recording itself untouched
}

TEST_F(Logmend, KeepsALogWithoutAStepByteForByte) {
  const std::string golden = std::string(DEPOWDER_SOURCE_DIR) + "/logs/static_cube.lcmlog";
  if (!std::ifstream(golden)) GTEST_SKIP() << golden << " is absent";
  std::string out;
  ASSERT_EQ(run({golden, path("golden.lcmlog")}, &out), 0) << out;
  EXPECT_NE(out.find(" events, 0 steps of the clock taken out"), std::string::npos) << out;
  EXPECT_TRUE(sameBytes(path("golden.lcmlog"), golden));
  EXPECT_EQ(out.find("clock stepped"), std::string::npos) << out;
}

TEST_F(Logmend, RefusesToWriteOverTheRecordingAndNamesAnUnreadableLog) {
  const Recording r = simulate();
  write(r, path("run.lcmlog"));
  std::string out;
  EXPECT_EQ(run({path("run.lcmlog"), path("run.lcmlog")}, &out), 2);
  EXPECT_NE(out.find("MENDED must be another file than RUN"), std::string::npos) << out;
  EXPECT_EQ(eventTimes(path("run.lcmlog")), r.recorded);
  EXPECT_EQ(run({path("missing.lcmlog")}, &out), 2);
  EXPECT_NE(out.find("cannot read LCM log '" + path("missing.lcmlog") + "'"), std::string::npos) << out;
}

}  // namespace
