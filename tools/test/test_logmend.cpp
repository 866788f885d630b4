// The steps of a recording host's clock taken out of a log's event times (log_time.hpp,
// depowder-logmend): on a simulated recording whose logger clock steps an hour back and, 10 s
// later, forward again, with a real silence of the whole cell after that; and on the golden log,
// which has no step (one event recorded 114 us before the one before it, as lcm-logger can) and
// must come out byte for byte as it went in.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/log_reader.hpp"
#include "depowder/node/log_time.hpp"
#include "depowder/process_under_test.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/robot_state_v1_t.hpp"
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

/// The bytes of `file`.
std::string bytesOf(const std::string& file) {
  std::ifstream f(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

/// Six events written by lcm::LogFile, each its own bytes; and a log damaged as recordings are:
/// event 0, 37 bytes of another file, event 1, event 2 with its channel length beyond LCM's 999,
/// events 3 and 4, and event 5 cut 10 bytes short (the logger killed mid-write).
struct DamagedLog {
  std::vector<std::string> event;  ///< each event's bytes
  std::string bytes;               ///< the damaged log
  std::int64_t garbage_at = 0, bad_header_at = 0, cut_at = 0;
};

DamagedLog damagedLog(const std::string& scratch) {
  DamagedLog d;
  {
    lcm::LogFile log(scratch, "w");
    for (int i = 0; i < 6; ++i)
      testutil::writeBytes(log, "CHANNEL_" + std::to_string(i), std::vector<std::uint8_t>(40 + i, std::uint8_t(i)),
                           1'795'000'000'000'000 + i);
  }
  const std::string all = bytesOf(scratch);
  for (std::size_t i = 0, at = 0; i < 6; at += d.event.back().size(), ++i)
    d.event.push_back(all.substr(at, 28 + 9 + 40 + i));  // header, "CHANNEL_i", data
  std::string bad = d.event[2];
  bad[20] = '\x00', bad[21] = '\x00', bad[22] = '\x13', bad[23] = '\x88';  // channel length 5000
  d.bytes = d.event[0];
  d.garbage_at = static_cast<std::int64_t>(d.bytes.size());
  d.bytes += std::string(37, 'x') + d.event[1];
  d.bad_header_at = static_cast<std::int64_t>(d.bytes.size());
  d.bytes += bad + d.event[3] + d.event[4];
  d.cut_at = static_cast<std::int64_t>(d.bytes.size());
  d.bytes += d.event[5].substr(0, d.event[5].size() - 10);
  return d;
}

TEST(LogReader, ReadsAWholeLogAsLcmDoes) {
  const std::string golden = std::string(DEPOWDER_SOURCE_DIR) + "/logs/static_cube.lcmlog";
  if (!std::ifstream(golden)) GTEST_SKIP() << golden << " is absent";
  lcm::LogFile lcm_log(golden, "r");
  node::LogReader reader(golden);
  std::size_t n = 0;
  for (const lcm::LogEvent* a; (a = lcm_log.readNextEvent()) != nullptr; ++n) {
    const lcm::LogEvent* b = reader.next();
    ASSERT_NE(b, nullptr) << "event " << n;
    EXPECT_EQ(b->eventnum, a->eventnum);
    EXPECT_EQ(b->timestamp, a->timestamp);
    EXPECT_EQ(b->channel, a->channel);
    ASSERT_EQ(b->datalen, a->datalen);
    EXPECT_EQ(std::memcmp(b->data, a->data, static_cast<std::size_t>(a->datalen)), 0) << "event " << n;
  }
  EXPECT_GT(n, 100u);
  EXPECT_EQ(reader.next(), nullptr);
  EXPECT_EQ(reader.events(), n);
  EXPECT_TRUE(reader.damage().empty()) << node::describe(reader.damage()[0]);
}

TEST(LogReader, GoesOnPastDamageAndNamesEveryByteItLeftOut) {
  const DamagedLog d = damagedLog(testing::TempDir() + "log_reader_event.lcmlog");
  std::FILE* file = fmemopen(const_cast<char*>(d.bytes.data()), d.bytes.size(), "rb");
  ASSERT_NE(file, nullptr);
  node::LogReader reader(file);
  std::vector<std::string> channels;
  for (const lcm::LogEvent* e; (e = reader.next()) != nullptr;) {
    channels.push_back(e->channel);
    EXPECT_EQ(e->datalen, 40 + (channels.back().back() - '0'));
  }
  std::fclose(file);
  EXPECT_EQ(channels, (std::vector<std::string>{"CHANNEL_0", "CHANNEL_1", "CHANNEL_3", "CHANNEL_4"}));
  const std::vector<node::LogDamage>& damage = reader.damage();
  ASSERT_EQ(damage.size(), 3u);
  EXPECT_EQ(damage[0].offset, d.garbage_at);
  EXPECT_EQ(damage[0].bytes, 37);
  EXPECT_FALSE(damage[0].at_end);
  EXPECT_EQ(damage[1].offset, d.bad_header_at);
  EXPECT_EQ(damage[1].bytes, static_cast<std::int64_t>(d.event[2].size()));
  EXPECT_EQ(damage[2].offset, d.cut_at);
  EXPECT_EQ(damage[2].bytes, static_cast<std::int64_t>(d.event[5].size()) - 10);
  EXPECT_TRUE(damage[2].at_end && damage[2].cut_short);
  EXPECT_EQ(node::describe(damage[0]),
            "bytes " + std::to_string(d.garbage_at) + ".." + std::to_string(d.garbage_at + 36) +
                " (37) are not an event (damage, or another file's bytes): skipped to the next whole event");
  EXPECT_NE(node::describe(damage[2]).find("cut short"), std::string::npos);
}

TEST(LogReader, TakesTheEventsALoggerRestartedMidWriteAppended) {
  // lcm-logger killed 30 bytes into event 1, restarted by the launcher with --append: events 2
  // and 3 follow the cut. Event 1's header claims their bytes; they must still be read.
  const DamagedLog d = damagedLog(testing::TempDir() + "log_reader_restart.lcmlog");
  std::string bytes = d.event[0] + d.event[1].substr(0, 30) + d.event[2] + d.event[3];
  std::FILE* file = fmemopen(bytes.data(), bytes.size(), "rb");
  ASSERT_NE(file, nullptr);
  node::LogReader reader(file);
  std::vector<std::string> channels;
  for (const lcm::LogEvent* e; (e = reader.next()) != nullptr;) channels.push_back(e->channel);
  std::fclose(file);
  EXPECT_EQ(channels, (std::vector<std::string>{"CHANNEL_0", "CHANNEL_2", "CHANNEL_3"}));
  ASSERT_EQ(reader.damage().size(), 1u);
  EXPECT_EQ(reader.damage()[0].offset, static_cast<std::int64_t>(d.event[0].size()));
  EXPECT_EQ(reader.damage()[0].bytes, 30);
  EXPECT_FALSE(reader.damage()[0].at_end);
}

TEST_F(Logmend, MendsADamagedLogIntoAWholeOne) {
  const DamagedLog d = damagedLog(path("event.lcmlog"));
  std::ofstream(path("damaged.lcmlog"), std::ios::binary) << d.bytes;
  // LCM's own reader, which lcm-logplayer plays with, stops at the first damage (LCM 1.3: at the
  // bytes after event 0, losing event 0 too).
  EXPECT_LT(eventTimes(path("damaged.lcmlog")).size(), 4u);
  std::string out;
  ASSERT_EQ(run({path("damaged.lcmlog"), path("mended.lcmlog")}, &out), 0) << out;
  EXPECT_NE(out.find("4 events, 0 steps of the clock taken out, 3 damaged stretches left out"), std::string::npos)
      << out;
  EXPECT_NE(out.find("are an event cut short at the end of the log"), std::string::npos) << out;
  lcm::LogFile mended(path("mended.lcmlog"), "r");
  std::vector<std::string> channels;
  for (const lcm::LogEvent* e; (e = mended.readNextEvent()) != nullptr;) {
    channels.push_back(e->channel);
    const int i = e->channel.back() - '0';
    EXPECT_EQ(e->timestamp, 1'795'000'000'000'000 + i);
    EXPECT_EQ(std::string(static_cast<const char*>(e->data), static_cast<std::size_t>(e->datalen)),
              std::string(static_cast<std::size_t>(40 + i), static_cast<char>(i)));
  }
  EXPECT_EQ(channels, (std::vector<std::string>{"CHANNEL_0", "CHANNEL_1", "CHANNEL_3", "CHANNEL_4"}));

  const std::string stl = "solid part\nendsolid part\n";
  std::ofstream(path("not_a_log.stl"), std::ios::binary) << stl;
  EXPECT_EQ(run({path("not_a_log.stl"), path("mended2.lcmlog")}, &out), 2);
  EXPECT_NE(out.find("is not an LCM log: none of its " + std::to_string(stl.size()) + " bytes is an event"),
            std::string::npos)
      << out;
  EXPECT_EQ(run({tool_.dir(), path("mended3.lcmlog")}, &out), 2);
  EXPECT_NE(out.find("cannot read LCM log '" + tool_.dir() + "': it is a directory"), std::string::npos) << out;
}

TEST(LegacyTypes, RobotStateV1HasTheFingerprintOfTheLayoutBeforeMeasured) {
  // robot_state_t's fingerprint before `measured` (its file at the commit before eeee3d1, through
  // lcm-gen; the first 8 bytes of each ROBOT_STATE recorded then): another one leaves them unread.
  EXPECT_EQ(static_cast<std::uint64_t>(robot_state_v1_t::getHash()), 0xd35f45a7f8444d07ULL);
  EXPECT_NE(robot_state_v1_t::getHash(), robot_state_t::getHash());
}

TEST_F(Logmend, WritesRobotStateRecordedBeforeMeasuredInThePresentType) {
  // Two cells' drivers (channels ROBOT_STATE and B_ROBOT_STATE), as a driver before `measured`
  // recorded them: the mode each message says, and whether the arm had been read then.
  struct Old {
    const char* channel;
    std::int8_t mode;
    const char* reason;
    bool measured;  // as the present driver would say
  };
  const Old olds[] = {
      {"ROBOT_STATE", robot_state_v1_t::MODE_DISCONNECTED, "controller unreachable", false},
      {"ROBOT_STATE", robot_state_v1_t::MODE_FAULT, "controller refused the session", false},  // joints all 0
      {"B_ROBOT_STATE", robot_state_v1_t::MODE_IDLE, "connected", true},
      {"ROBOT_STATE", robot_state_v1_t::MODE_IDLE, "connected", true},
      {"ROBOT_STATE", robot_state_v1_t::MODE_FOLLOWING, "following plan 3", true},
      {"B_ROBOT_STATE", robot_state_v1_t::MODE_ESTOPPED, "ESTOP active", true},  // the arm read, stopped
      {"ROBOT_STATE", robot_state_v1_t::MODE_FAULT, "controller error: slvMove late", true},
      {"ROBOT_STATE", robot_state_v1_t::MODE_HOLDING, "stale plan", true},
      {"ROBOT_STATE", robot_state_v1_t::MODE_DISCONNECTED, "controller connection lost", false},
      {"ROBOT_STATE", robot_state_v1_t::MODE_ESTOPPED, "ESTOP active", false},  // while disconnected
      {"B_ROBOT_STATE", robot_state_v1_t::MODE_FAULT, "controller error", true},
  };
  const std::size_t n = std::size(olds);
  std::vector<robot_state_v1_t> sent;
  {
    lcm::LogFile log(path("old.lcmlog"), "w");
    ASSERT_TRUE(log.good());
    for (std::size_t i = 0; i < n; ++i) {
      robot_state_v1_t m{};
      m.utime = 1'795'000'000 * kS + static_cast<std::int64_t>(i) * 8000;
      m.mode = olds[i].mode;
      m.mode_reason = olds[i].reason;
      for (int j = 0; j < 6; ++j) {
        m.q[j] = i == 1 ? 0.0 : 0.1 * static_cast<double>(i) + 0.01 * j;
        m.qd[j] = -0.02 * j;
      }
      m.T_cell_nozzle.position[2] = 0.3 + 0.001 * static_cast<double>(i);
      m.T_cell_nozzle.orientation[0] = 1;
      m.tool = static_cast<std::int8_t>(i % 3);
      m.plan_id = static_cast<std::int64_t>(i) - 1;
      m.waypoint_index = static_cast<std::int32_t>(2 * i);
      m.plan_utime = m.utime - 50'000;
      sent.push_back(m);
      ASSERT_EQ(testutil::writeMessage(log, olds[i].channel, m, m.utime), 0);
    }
    robot_state_t present{};  // a message in the present type: kept byte for byte
    present.mode = robot_state_t::MODE_IDLE;
    present.measured = true;
    ASSERT_EQ(testutil::writeMessage(log, "ROBOT_STATE", present, sent.back().utime + 8000), 0);
    // The legacy fingerprint with too few bytes after it: not decodable, kept as recorded.
    std::vector<std::uint8_t> cut = testutil::encoded(sent[0]);
    cut.resize(20);
    ASSERT_EQ(testutil::writeBytes(log, "ROBOT_STATE", cut, sent.back().utime + 16000), 0);
  }
  std::string out;
  ASSERT_EQ(run({path("old.lcmlog"), path("new.lcmlog")}, &out), 0) << out;
  EXPECT_NE(out.find("11 ROBOT_STATE recorded before robot_state_t gained `measured` written as robot_state_t, "
                     "7 of them measured"),
            std::string::npos)
      << out;

  lcm::LogFile log(path("new.lcmlog"), "r");
  ASSERT_TRUE(log.good());
  for (std::size_t i = 0; i < n; ++i) {
    const lcm::LogEvent* e = log.readNextEvent();
    ASSERT_NE(e, nullptr) << i;
    EXPECT_EQ(e->channel, olds[i].channel);
    robot_state_t m;
    ASSERT_GE(m.decode(e->data, 0, e->datalen), 0) << "message " << i << " not in the present type";
    const robot_state_v1_t& was = sent[i];
    EXPECT_EQ(e->timestamp, was.utime);
    EXPECT_EQ(m.measured, olds[i].measured) << i << ": " << olds[i].reason;
    EXPECT_EQ(m.utime, was.utime);
    EXPECT_EQ(m.mode, was.mode);
    EXPECT_EQ(m.mode_reason, was.mode_reason);
    for (int j = 0; j < 6; ++j) {
      EXPECT_EQ(m.q[j], was.q[j]);
      EXPECT_EQ(m.qd[j], was.qd[j]);
    }
    EXPECT_EQ(m.T_cell_nozzle.position[2], was.T_cell_nozzle.position[2]);
    EXPECT_EQ(m.T_cell_nozzle.orientation[0], 1.0);
    EXPECT_EQ(m.tool, was.tool);
    EXPECT_EQ(m.plan_id, was.plan_id);
    EXPECT_EQ(m.waypoint_index, was.waypoint_index);
    EXPECT_EQ(m.plan_utime, was.plan_utime);
  }
  const lcm::LogEvent* present = log.readNextEvent();
  ASSERT_NE(present, nullptr);
  robot_state_t m;
  EXPECT_EQ(m.decode(present->data, 0, present->datalen), present->datalen);
  EXPECT_TRUE(m.measured);
  const lcm::LogEvent* cut = log.readNextEvent();
  ASSERT_NE(cut, nullptr);
  EXPECT_EQ(cut->datalen, 20);
  EXPECT_EQ(log.readNextEvent(), nullptr);

  // Without MENDED it only counts them.
  ASSERT_EQ(run({path("old.lcmlog")}, &out), 0) << out;
  EXPECT_NE(out.find("11 ROBOT_STATE recorded before robot_state_t gained `measured`, 7 of them measured"),
            std::string::npos)
      << out;
}

}  // namespace
