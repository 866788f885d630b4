// Every depowder type round-trips; truncated, corrupted and wrong-type buffers are
// rejected and counted by the Bus, never crash it.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <random>

#include "depowder/depth_image_t.hpp"
#include "depowder/estop_t.hpp"
#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/robot_state_v1_t.hpp"
#include "depowder/sim_truth_t.hpp"

using namespace depowder;

namespace {

template <class Msg>
std::vector<std::uint8_t> encode(const Msg& m) {
  std::vector<std::uint8_t> buf(m.getEncodedSize());
  EXPECT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return buf;
}

template <class Msg>
Msg roundTrip(const Msg& m) {
  const auto buf = encode(m);
  Msg out;
  EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  EXPECT_EQ(encode(out), buf);  // byte-identical re-encoding
  return out;
}

// Every truncation and a few corruptions of the header must be refused.
template <class Msg>
void expectTruncationsRejected(const Msg& m) {
  const auto buf = encode(m);
  for (std::size_t n = 0; n < buf.size(); ++n) {
    Msg out;
    ASSERT_LT(out.decode(buf.data(), 0, static_cast<int>(n)), 0)
        << "accepted " << n << " of " << buf.size() << " bytes";
  }
  auto bad = buf;
  bad[0] ^= 0xFF;  // fingerprint
  Msg out;
  EXPECT_LT(out.decode(bad.data(), 0, static_cast<int>(bad.size())), 0);
}

pose_t somePose() { return node::toMsg(makePoseRpy({0.1, -0.2, 0.3}, 0.1, 0.2, 0.3)); }

}  // namespace

TEST(LcmTypes, DepthImage) {
  depth_image_t m{};
  m.utime = 123;
  m.camera = "LEFT";
  m.width = 4;
  m.height = 2;
  m.fx = m.fy = 100;
  m.depth_unit = 0.00025f;
  m.T_cell_camera = somePose();
  m.num_bytes = 16;
  m.data.assign(16, 7);
  const auto out = roundTrip(m);
  EXPECT_EQ(out.camera, "LEFT");
  EXPECT_EQ(out.data, m.data);
  expectTruncationsRejected(m);
}

TEST(LcmTypes, PointCloudIsCompactAndAccurate) {
  Cloud cloud;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (int i = 0; i < 20000; ++i) cloud.emplace_back(u(rng), u(rng), u(rng) + 0.2);
  int dropped = -1;
  point_cloud_t m = node::encodeCloud(cloud, 42, 0.0005, &dropped);
  EXPECT_EQ(dropped, 0);
  const auto buf = encode(m);
  EXPECT_LT(buf.size(), 6u * cloud.size() + 200);  // 6 bytes a point
  const auto decoded = node::decodeCloud(roundTrip(m));
  ASSERT_TRUE(decoded);
  ASSERT_EQ(decoded->size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    ASSERT_LE(((*decoded)[i] - cloud[i]).cwiseAbs().maxCoeff(), 0.00025 + 1e-6);  // half a quantum
  // Every truncation, on the first 64 points: the decoder's paths are the same for any count,
  // and each truncated decode allocates the whole array first, so every truncation of all
  // 20000 points (120 kB) took two minutes of the suite.
  expectTruncationsRejected(node::encodeCloud(Cloud(cloud.begin(), cloud.begin() + 64), 42, 0.0005));
}

TEST(LcmTypes, PointCloudDropsNanAndRejectsBadHeader) {
  Cloud cloud{{0, 0, 0}, {NAN, 0, 0}, {0.1, 0, 0}};
  int dropped = 0;
  point_cloud_t m = node::encodeCloud(cloud, 1, 0.0005, &dropped);
  EXPECT_EQ(dropped, 1);
  EXPECT_EQ(m.num_points, 2);
  m.resolution = 0;
  std::string why;
  EXPECT_FALSE(node::decodeCloud(m, &why));
  EXPECT_NE(why.find("resolution"), std::string::npos);
}

// The message's count (of an array, or a string's length) at `at` bytes from its end, set to
// `count`, then decoded.
template <class Msg>
int decodeWithCount(const Msg& m, std::size_t at, std::int32_t count) {
  auto buf = encode(m);
  EXPECT_EQ(__int32_t_encode_array(buf.data(), static_cast<int>(buf.size() - at), 4, &count, 1), 4);
  Msg out;
  return out.decode(buf.data(), 0, static_cast<int>(buf.size()));
}

long peakRssKb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// A count beyond the bytes left (or negative) is refused before the array is allocated: the
// decoders as lcm-gen writes them resized first (1e8 points: 2.3 GB and 9 s for a 57-byte
// message; a negative count threw). lcmtypes/bound_lengths.cmake adds the check.
TEST(LcmTypes, ArrayCountBeyondTheMessageIsRefusedBeforeAllocating) {
  point_cloud_t cloud{};  // ... num_points, xyz[], num_sources, sources[], source_utimes[]
  cloud.frame = "cell";
  heartbeat_t beat{};     // ... num_stats, stat_names[], stat_values[]
  nozzle_plan_t plan{};   // ... num_waypoints, waypoints[]
  progress_t progress{};  // ... num_contour, contour[][3], num_band, band[][3]
  const long before = peakRssKb();
  for (const std::int32_t count : {100000000, std::numeric_limits<std::int32_t>::max(), -1}) {
    SCOPED_TRACE(count);
    EXPECT_LT(decodeWithCount(cloud, 8, count), 0);  // num_points
    EXPECT_LT(decodeWithCount(cloud, 4, count), 0);  // num_sources
    EXPECT_LT(decodeWithCount(beat, 4, count), 0);
    EXPECT_LT(decodeWithCount(plan, 4, count), 0);
    EXPECT_LT(decodeWithCount(progress, 8, count), 0);  // num_contour
    EXPECT_LT(decodeWithCount(progress, 4, count), 0);  // num_band
  }
  EXPECT_LT(peakRssKb() - before, 64 * 1024) << "kB of peak memory grown by decoding the messages above";
  // A count that fits the bytes left is still read (and fails on the missing elements).
  EXPECT_LT(decodeWithCount(plan, 4, 1), 0);
  EXPECT_EQ(decodeWithCount(plan, 4, 0), static_cast<int>(encode(plan).size()));
}

// A string's length on the wire counts its NUL: 0 or below is refused, not thrown from
// std::string::assign (as lcm-gen's decoders did; a log tool then stopped at the message).
TEST(LcmTypes, StringLengthBelowOneIsRefused) {
  part_pose_t pose{};  // hash, utime, then the length of `part`
  pose.part = "pipe";
  const std::size_t from_end = encode(pose).size() - 16;
  for (const std::int32_t length : {0, -5, std::numeric_limits<std::int32_t>::min()}) {
    SCOPED_TRACE(length);
    EXPECT_LT(decodeWithCount(pose, from_end, length), 0);
  }
  EXPECT_EQ(decodeWithCount(pose, from_end, 5), static_cast<int>(encode(pose).size()));  // "pipe" and its NUL
}

TEST(LcmTypes, PartPose) {
  part_pose_t m{};
  m.part = "pipe";
  m.method = "cu";
  m.status = part_pose_t::TRACKING;
  m.T_cell_part = somePose();
  m.template_size = 2;
  m.template_xyz = {{1, 2, 3}, {4, 5, 6}};
  EXPECT_EQ(roundTrip(m).template_xyz, m.template_xyz);
  expectTruncationsRejected(m);
}

TEST(LcmTypes, ProgressPlanStateTruthHeartbeatEstop) {
  progress_t p{};
  p.part = "cube";
  p.phase = progress_t::PHASE_VACUUM_TRACKED;
  p.num_contour = 1;
  p.contour = {{0.1f, 0.2f, 0.3f}};
  p.T_cell_part = somePose();
  EXPECT_EQ(roundTrip(p).contour, p.contour);
  expectTruncationsRejected(p);

  nozzle_plan_t plan{};
  plan.num_waypoints = 2;
  plan.waypoints.resize(2);
  plan.waypoints[1].tool = waypoint_t::TOOL_AIR;
  plan.waypoints[0].T_cell_nozzle = plan.waypoints[1].T_cell_nozzle = somePose();
  EXPECT_EQ(roundTrip(plan).waypoints[1].tool, +waypoint_t::TOOL_AIR);
  expectTruncationsRejected(plan);

  robot_state_t rs{};
  rs.mode = robot_state_t::MODE_FOLLOWING;
  rs.measured = true;
  rs.T_cell_nozzle = somePose();
  EXPECT_EQ(roundTrip(rs).mode, +robot_state_t::MODE_FOLLOWING);
  EXPECT_TRUE(roundTrip(rs).measured);
  expectTruncationsRejected(rs);

  sim_truth_t t{};
  t.num_parts = 1;
  t.parts.resize(1);
  t.parts[0].part = "owl";
  t.parts[0].T_cell_part = somePose();
  t.T_cell_nozzle = somePose();
  EXPECT_EQ(roundTrip(t).parts[0].part, "owl");
  expectTruncationsRejected(t);

  heartbeat_t h{};
  h.process = "x";
  h.num_stats = 1;
  h.stat_names = {"frame_ms"};
  h.stat_values = {1.5};
  EXPECT_EQ(roundTrip(h).stat_values, h.stat_values);
  expectTruncationsRejected(h);

  estop_t e{};
  e.stop = true;
  e.source = "test";
  EXPECT_TRUE(roundTrip(e).stop);
  expectTruncationsRejected(e);
}

TEST(Convert, PoseRoundTripAndRejection) {
  const Pose p = makePoseRpy({1, 2, 3}, 0.3, -0.2, 0.1);
  const auto back = node::fromMsg(node::toMsg(p));
  ASSERT_TRUE(back);
  EXPECT_TRUE(back->isApprox(p, 1e-12));
  pose_t bad = node::toMsg(p);
  bad.orientation[2] = NAN;
  std::string why;
  EXPECT_FALSE(node::fromMsg(bad, &why));
  EXPECT_NE(why.find("NaN"), std::string::npos);
  bad = node::toMsg(p);
  bad.orientation[0] *= 3;
  EXPECT_FALSE(node::fromMsg(bad, &why));
  EXPECT_NE(why.find("not unit"), std::string::npos);
}

TEST(Bus, GarbageAndWrongTypesAreCountedNotFatal) {
  node::Bus bus("memq://");
  int got = 0;
  bus.subscribe<estop_t>("ESTOP", [&](const estop_t&, const std::string&) { ++got; });
  bus.subscribe<heartbeat_t>("HEARTBEAT",
                             [&](const heartbeat_t&, const std::string&) { throw std::runtime_error("boom"); });
  std::mt19937 rng(5);
  for (int i = 0; i < 50; ++i) {
    std::vector<std::uint8_t> junk(rng() % 200);
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    bus.publishRaw("ESTOP", junk.data(), static_cast<int>(junk.size()));
  }
  heartbeat_t wrong{};
  bus.publish("ESTOP", wrong);  // valid message, wrong type
  estop_t ok{};
  ok.stop = true;
  bus.publish("ESTOP", ok);
  bus.publish("HEARTBEAT", wrong);
  while (bus.spinOnce(0) > 0) {
  }
  EXPECT_EQ(got, 1);
  EXPECT_EQ(bus.counters().decode_errors, 51);
  EXPECT_EQ(bus.counters().handler_errors, 1);
  const auto errors = bus.takeErrors();
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors.back().find("boom"), std::string::npos);
}

// A ROBOT_STATE recorded before robot_state_t gained `measured`, played again: refused and
// counted like any message of another type, and the error says what it is and what converts it.
TEST(Bus, ALegacyRobotStateIsNamedWithItsConversion) {
  node::Bus bus("memq://");
  int got = 0;
  bus.subscribe<robot_state_t>("ROBOT_STATE", [&](const robot_state_t&, const std::string&) { ++got; });
  robot_state_v1_t old{};
  old.mode = robot_state_v1_t::MODE_IDLE;
  bus.publish("ROBOT_STATE", old);
  heartbeat_t other{};
  bus.publish("ROBOT_STATE", other);
  while (bus.spinOnce(0) > 0) {
  }
  EXPECT_EQ(got, 0);
  EXPECT_EQ(bus.counters().decode_errors, 2);
  const auto errors = bus.takeErrors();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("on ROBOT_STATE: robot_state_t as recorded before it gained `measured`"), std::string::npos)
      << errors[0];
  EXPECT_NE(errors[0].find("depowder-logmend OLD.lcmlog NEW.lcmlog"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("(wrong type or corrupt)"), std::string::npos) << errors[1];
}

// drain() handles what has already arrived, up to its limit, and returns at once when nothing is
// waiting.
TEST(Bus, DrainHandlesWhatHasArrivedWithoutWaiting) {
  node::Bus bus("memq://");
  int got = 0;
  bus.subscribe<estop_t>("ESTOP", [&](const estop_t&, const std::string&) { ++got; });
  estop_t e{};
  for (int i = 0; i < 5; ++i) bus.publish("ESTOP", e);
  EXPECT_EQ(bus.drain(3), 3);
  EXPECT_EQ(got, 3);
  EXPECT_EQ(bus.drain(), 2);
  EXPECT_EQ(got, 5);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(bus.drain(), 0);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500));
}

TEST(Bus, PrefixSeparatesCells) {
  node::Bus a("memq://", "CELL_A_");
  EXPECT_EQ(a.channel("POINTS"), "CELL_A_POINTS");
}
